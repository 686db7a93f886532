"""Solver answers by question, so that re-checking an unchanged spec asks z3
nothing (the editor re-checks on every change).

Entries are small JSON objects keyed by a digest of the question: in memory, and
as files in `RMV_CACHE_DIR` (default `$XDG_CACHE_HOME/rmvdsl` or `~/.cache/rmvdsl`;
empty: no files). A cache that cannot be read or written only costs time. Both are
bounded (the sizes below): memory drops its oldest half when full, and a folder is
pruned of files written more than MAX_AGE_DAYS ago, then of the oldest. (Reads do
not touch a file: a re-check after an edit reads thousands of answers, and a
syscall each would cost more than answering again the few a prune drops.)
"""

from __future__ import annotations

import atexit
import hashlib
import json
import os
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from rmvdsl.util.folders import cache_folder

# How much is kept, in one place: answers in memory (a long editor session), files
# per folder of the cache, and how old an unread file may grow.
MEMORY_ENTRIES = 200_000
FOLDER_ENTRIES = 50_000  # about 25 MB of answers
STORED_CHECKS = 2_000  # whole `rmv check` outputs (rmvdsl.commands.stored)
MAX_AGE_DAYS = 90  # since written
PRUNE_EVERY = 1_000  # writes between two looks at a folder's size


@dataclass
class Cache:
    folder: str | None = None
    memory: dict[str, dict[str, Any]] = field(default_factory=dict)
    hits: int = 0

    @classmethod
    def default(cls) -> Cache:
        folder = cache_folder()
        return cls(os.path.join(folder, "answers") if folder else None)

    def get(self, key: str) -> dict[str, Any] | None:
        if key in self.memory:
            self.hits += 1
            return self.memory[key]
        if self.folder is None:
            return None
        path = os.path.join(self.folder, key + ".json")
        try:
            text = _WRITER.unwritten(path)
            if text is None:
                with open(path, encoding="utf-8") as handle:
                    text = handle.read()
            value = json.loads(text)
        except (OSError, ValueError):
            return None
        if not isinstance(value, dict):
            return None
        self._remember(key, value)
        self.hits += 1
        return value

    def put(self, key: str, value: dict[str, Any]) -> None:
        self._remember(key, value)
        if self.folder is not None:
            _WRITER.write(self.folder, key, json.dumps(value))

    def _remember(self, key: str, value: dict[str, Any]) -> None:
        if len(self.memory) >= MEMORY_ENTRIES:
            for old in list(self.memory)[: MEMORY_ENTRIES // 2]:  # the oldest half
                del self.memory[old]
        self.memory[key] = value


class _Writer:
    """Writes the answers' files on a thread of its own. A file cost 0.2 to 1 ms to
    write here, and a first check writes thousands (2 of a large spec's 15 s): the
    solver need not wait for the disk. Until its file is written an answer is read
    from here, by every Cache of the process; other processes see it once written:
    each check ends by waiting for its writes (`flush`), and so does the process."""

    def __init__(self) -> None:
        self.pending: dict[str, str] = {}  # path: text, oldest first
        self.changed = threading.Condition()
        self.thread: threading.Thread | None = None
        self.written: dict[str, int] = {}  # by folder: pruned every PRUNE_EVERY

    def write(self, folder: str, key: str, text: str) -> None:
        with self.changed:
            self.pending[os.path.join(folder, key + ".json")] = text
            if self.thread is None:
                self.thread = threading.Thread(target=self._run, name="rmv-cache", daemon=True)
                self.thread.start()
            self.changed.notify_all()

    def unwritten(self, path: str) -> str | None:
        with self.changed:
            return self.pending.get(path)

    def flush(self, timeout: float = 30) -> None:
        """Wait until every answer put so far is on disk (or could not be written)."""
        with self.changed:
            self.changed.wait_for(lambda: not self.pending, timeout)

    def _run(self) -> None:
        while True:
            with self.changed:
                self.changed.wait_for(lambda: bool(self.pending))
                path, text = next(iter(self.pending.items()))
            _write_file(path, text)  # outside the lock: reads go on meanwhile
            folder = os.path.dirname(path)
            count = self.written.get(folder, 0)
            self.written[folder] = count + 1
            if count % PRUNE_EVERY == 0:
                prune(folder)
            with self.changed:
                if self.pending.get(path) is text:  # not put again meanwhile
                    del self.pending[path]
                self.changed.notify_all()


def _write_file(path: str, text: str) -> None:
    """Whole or not at all (a reader never sees half a file); a cache that cannot be
    written only costs time."""
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        temporary = f"{os.path.dirname(path)}/.{os.path.basename(path)}.{os.getpid()}"
        with open(temporary, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(temporary, path)
    except OSError:
        pass


_WRITER = _Writer()


def _new_writer() -> None:
    """A forked child has no writer thread, and its parent writes what was pending."""
    global _WRITER
    _WRITER = _Writer()


os.register_at_fork(after_in_child=_new_writer)


def flush() -> None:
    """Wait until the answers put so far are written (other processes read them)."""
    _WRITER.flush()


atexit.register(flush)


def prune(folder: str, entries: int = FOLDER_ENTRIES, days: float = MAX_AGE_DAYS) -> int:
    """Remove the files of `folder` written more than `days` ago, then the oldest
    past `entries`. The number removed."""
    try:
        with os.scandir(folder) as found:
            files = [(e.stat().st_mtime, e.path) for e in found if e.is_file()]
    except OSError:
        return 0
    files.sort()
    cutoff = time.time() - days * 86400
    stale = [path for mtime, path in files if mtime < cutoff]
    keep = len(files) - len(stale)
    excess = [path for _, path in files[len(stale) :]][: max(0, keep - entries)]
    removed = 0
    for path in [*stale, *excess]:
        try:
            os.remove(path)
            removed += 1
        except OSError:
            pass
    return removed


@dataclass
class Layered(Cache):
    """Answers known for one check (those not to keep, such as answers a time limit
    cut short) over the cache that keeps the rest: reads look here first, writes
    go below."""

    below: Cache = field(default_factory=Cache)

    def get(self, key: str) -> dict[str, Any] | None:
        if key in self.memory:
            return self.memory[key]
        return self.below.get(key)

    def put(self, key: str, value: dict[str, Any]) -> None:
        self.below.put(key, value)


def digest(*parts: object) -> str:
    """A key for a question: its parts as text, hashed."""
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:32]


_DEFAULT: Cache | None = None


def default_cache() -> Cache:
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = Cache.default()
    return _DEFAULT


def use_cache(cache: Cache | None) -> None:
    """Make `cache` the one every check uses from now on (None: the default again,
    from RMV_CACHE_DIR). Benchmarks start each measurement from an empty one."""
    global _DEFAULT
    _DEFAULT = cache
