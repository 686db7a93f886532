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

import hashlib
import json
import os
import time
from dataclasses import dataclass, field
from typing import Any

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

    writes: int = 0

    def get(self, key: str) -> dict[str, Any] | None:
        if key in self.memory:
            self.hits += 1
            return self.memory[key]
        if self.folder is None:
            return None
        try:
            with open(os.path.join(self.folder, key + ".json"), encoding="utf-8") as handle:
                value = json.load(handle)
        except (OSError, ValueError):
            return None
        if not isinstance(value, dict):
            return None
        self._remember(key, value)
        self.hits += 1
        return value

    def put(self, key: str, value: dict[str, Any]) -> None:
        self._remember(key, value)
        if self.folder is None:
            return
        try:
            os.makedirs(self.folder, exist_ok=True)
            temporary = os.path.join(self.folder, f".{key}.{os.getpid()}")
            with open(temporary, "w", encoding="utf-8") as handle:
                json.dump(value, handle)
            os.replace(temporary, os.path.join(self.folder, key + ".json"))
        except OSError:
            return
        if self.writes % PRUNE_EVERY == 0:
            prune(self.folder)
        self.writes += 1

    def _remember(self, key: str, value: dict[str, Any]) -> None:
        if len(self.memory) >= MEMORY_ENTRIES:
            for old in list(self.memory)[: MEMORY_ENTRIES // 2]:  # the oldest half
                del self.memory[old]
        self.memory[key] = value


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


def cache_folder() -> str | None:
    """Where rmvdsl keeps files between processes: `RMV_CACHE_DIR`, else
    `$XDG_CACHE_HOME/rmvdsl` or `~/.cache/rmvdsl`; None when RMV_CACHE_DIR is empty."""
    folder = os.environ.get("RMV_CACHE_DIR")
    if folder is None:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        folder = os.path.join(base, "rmvdsl")
    return folder or None


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
