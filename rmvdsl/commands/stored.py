"""A whole `rmv check`'s output, stored between processes: a re-check of specs
whose every input is unchanged prints the stored output without parsing anything.

An entry is keyed by what the command was asked (the files named, the options,
the folder it ran in, the environment variables that choose message folders, the
version of rmvdsl and the install of rosbags and z3, and the size and
modification time of each of rmvdsl's own files, so an edited checkout never
answers with what its older code printed) and holds what it printed, its exit
code, and the inputs it read: every file (the specs, their imports, rmv.toml,
each message definition) by the SHA-256 of its bytes, each file looked for and
not found, and each message folder by its modification time (a file added or
removed changes it). The entry answers only while every one of them is as it
was; then the check runs as usual and replaces it. One entry per key: editing a
spec replaces its entry, so the folder grows only with the specs and options checked.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from importlib.util import find_spec
from typing import Any

import rmvdsl
from rmvdsl import __version__
from rmvdsl.util.cache import STORED_CHECKS, prune
from rmvdsl.util.folders import cache_folder

FORMAT = 1
# Environment variables that change which message definitions a check finds.
ENVIRONMENT = ("AMENT_PREFIX_PATH", "ROS_PACKAGE_PATH", "CMAKE_PREFIX_PATH", "ROS_DISTRO")


# A check that reported one of these is not stored: a missing file or folder it
# names may appear, and an undecided property may be decided with more time.
NOT_STORED = frozenset({"RMV001", "RMV003", "RMV306", "RMV307", "RMV516"})


def storable(codes: Iterable[str]) -> bool:
    """May a check that reported these codes answer a later run?"""
    return NOT_STORED.isdisjoint(codes)


@dataclass(frozen=True)
class Stored:
    stdout: str
    stderr: str
    code: int


def key(arguments: Sequence[str]) -> str:
    """The key of a check: its arguments, where and with what it runs."""
    parts = {
        "format": FORMAT,
        "arguments": list(arguments),
        "folder": os.getcwd(),
        "environment": {name: os.environ.get(name) for name in ENVIRONMENT},
        "versions": [__version__, _installed("rosbags", "rosbags"), _installed("z3", "z3-solver")],
        "code": _code_stamp(),
    }
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()[:32]


def _code_stamp() -> list[tuple[str, int, int]]:
    """Each file of the rmvdsl package with its size and modification time (about
    150 `stat` calls: a millisecond)."""
    root = os.path.abspath(next(iter(rmvdsl.__path__)))  # no importlib.resources: 15 ms
    out: list[tuple[str, int, int]] = []
    stack = [root]
    while stack:
        with os.scandir(stack.pop()) as entries:
            for entry in entries:
                if entry.is_dir():
                    if entry.name != "__pycache__":
                        stack.append(entry.path)
                    continue
                info = entry.stat()
                out.append((os.path.relpath(entry.path, root), info.st_size, info.st_mtime_ns))
    return sorted(out)


def _installed(module: str, distribution: str) -> list[str] | str | None:
    """The version of `distribution` (which holds `module`) installed, as the name
    of its `.dist-info` folder beside the module says it (`rosbags-0.11.9.dist-info`),
    without importing either or importlib.metadata (whose import was a sixth of a
    stored re-check); where no such folder is found, importlib.metadata's answer."""
    spec = find_spec(module)
    places = spec.submodule_search_locations if spec is not None else None
    if places:
        folder = os.path.dirname(next(iter(places)))
        prefix = distribution.replace("-", "_") + "-"
        with contextlib.suppress(OSError):
            found = sorted(n for n in os.listdir(folder)
                           if n.startswith(prefix) and n.endswith(".dist-info"))  # fmt: skip
            if found:
                return found
    from importlib import metadata

    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


def _path(entry: str) -> str | None:
    folder = cache_folder()
    return os.path.join(folder, "checks", entry + ".json") if folder else None


def lookup(entry: str) -> Stored | None:
    """The stored output of the check `entry`, if every input it read is unchanged."""
    path = _path(entry)
    if path is None:
        return None
    try:
        with open(path, encoding="utf-8") as handle:
            stored = json.load(handle)
        files, folders = stored["files"], stored["folders"]
        if any(_digest(name) != digest for name, digest in files):
            return None
        if any(_mtime(name) != mtime for name, mtime in folders):
            return None
        return Stored(stored["stdout"], stored["stderr"], int(stored["code"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def store(entry: str, output: Stored, files: Iterable[str], folders: Iterable[str]) -> None:
    """Remember a check's output with the files and folders it read (a cache that
    cannot be written only costs time)."""
    path = _path(entry)
    if path is None:
        return
    value = {
        "stdout": output.stdout, "stderr": output.stderr, "code": output.code,
        "files": [[name, _digest(name)] for name in sorted(set(files))],
        "folders": [[name, _mtime(name)] for name in sorted(set(folders))],
    }  # fmt: skip
    with contextlib.suppress(OSError):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        temporary = f"{path}.{os.getpid()}"
        with open(temporary, "w", encoding="utf-8") as handle:
            json.dump(value, handle)
        os.replace(temporary, path)
    prune(os.path.dirname(path), STORED_CHECKS)


def inputs(specs: Iterable[str], sources: Iterable[Any]) -> list[str]:
    """The files a check of `specs` read, to store with what it found: each source
    it read that is a file (specs, imports, message definitions), and the
    `rmv.toml` it looked for beside each spec, there or not."""
    read = [source.path for source in sources if os.path.isfile(source.path)]
    return [*read, *(os.path.join(os.path.dirname(p) or ".", "rmv.toml") for p in specs)]


def _digest(path: str) -> str | None:
    """The SHA-256 of a file's bytes; None for a file that is not there."""
    try:
        with open(path, "rb") as handle:
            return hashlib.sha256(handle.read()).hexdigest()
    except OSError:
        return None


def _mtime(path: str) -> int | None:
    try:
        return os.stat(path).st_mtime_ns
    except OSError:
        return None
