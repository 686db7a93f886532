"""The methods `dataclasses` writes, compiled once per machine rather than in every
process.

`@dataclass` writes each class's `__init__`, `__eq__`, `__repr__`, `__hash__` (and a
frozen class's `__setattr__` and `__delattr__`) as Python source and compiles it
when the class is made: every process that imports rmvdsl compiled about 900 such
functions (136 ms of the 558 ms its stages took to import here, a sixth of an
`rmv check` of the CARLA example after an edit, again in each solver worker).
Their source is the same in every process, so the compiled code is kept like a
.pyc: in rmvdsl's cache folder (rmvdsl.util.folders), one file per Python version,
read once when rmvdsl is imported (each source's code marshalled on its own,
unmarshalled when run) and written again at exit when a process compiled source it
did not hold.

`dataclasses` calls `exec(source, globals, namespace)` by name; the module gets an
`exec` of its own that runs the same source's kept code. The code compiled from a
source is the same code (same text, same file name "<string>", same flags), so
the classes are the same; a source not kept is compiled as before, and a missing,
unreadable or damaged file only costs the compiling. The file is trusted as
Python trusts its own __pycache__, and only when the user owns it.
"""

from __future__ import annotations

import atexit
import builtins
import contextlib
import dataclasses
import itertools
import marshal
import os
import sys
from types import CodeType
from typing import Any

from rmvdsl.util.folders import cache_folder

# Sources kept, the last process's first: rmvdsl's own are about 800, and a replay
# adds the message classes rosbags makes (a file of 1,200 reads in 9 ms here).
MAX_KEPT = 3_000
# By the interpreter and its exact version: marshal's format and the bytecode are
# its own (importlib.util's MAGIC_NUMBER would say less, and import more); and by
# how this module compiles (FORMAT: code kept by an earlier way is not read).
FORMAT = 2
_FILE_NAME = f"dataclasses-{FORMAT}-{sys.implementation.cache_tag}-{sys.hexversion:x}.marshal"


class _Kept:
    """Compiled code by source (marshalled: a process unmarshals only the code it
    runs), and what this process ran."""

    def __init__(self, path: str | None) -> None:
        self.path = path
        self.codes: dict[str, bytes] = _read(path) if path else {}
        self.used: dict[str, bytes] = {}  # by this process
        self.new = False

    def exec(self, source: Any, globals: Any = None, locals: Any = None) -> None:
        if type(source) is str:
            code, kept = self._code(source)
            self.used[source] = kept
            source = code
        builtins.exec(source, globals, locals)

    def _code(self, source: str) -> tuple[CodeType, bytes]:
        kept = self.codes.get(source)
        if kept is not None:
            try:
                code = marshal.loads(kept)
            except (EOFError, ValueError, TypeError):
                code = None
            if type(code) is CodeType:
                return code, kept
        # Compiled as `exec` compiles the source for `dataclasses`, whose module has
        # no `from __future__` import: this one's would make annotations strings.
        code = compile(source, "<string>", "exec", dont_inherit=True)
        self.codes[source] = kept = marshal.dumps(code)
        self.new = True
        return code, kept

    def write(self) -> None:
        """This process's code, then what the file held, up to MAX_KEPT sources:
        written whole or not at all, when this process compiled anything."""
        if not self.new or self.path is None:
            return
        codes = dict(self.used)  # this process's code wins over the file's
        for source, code in _read(self.path).items():
            codes.setdefault(source, code)
        codes = dict(itertools.islice(codes.items(), MAX_KEPT))
        temporary = f"{self.path}.{os.getpid()}"
        try:
            os.makedirs(os.path.dirname(self.path), exist_ok=True)
            with open(temporary, "wb") as handle:
                marshal.dump(codes, handle)
            os.replace(temporary, self.path)
        except (OSError, ValueError):
            with contextlib.suppress(OSError):
                os.remove(temporary)


def _read(path: str) -> dict[str, bytes]:
    """The kept code, if the file is the user's own: code another user wrote (a
    cache folder shared with others) is never run, and is written over."""
    try:
        with open(path, "rb") as handle:
            if not _own(handle.fileno()):
                return {}
            found = marshal.loads(handle.read())  # marshal.load reads a file in bits: 8x slower
    except (OSError, EOFError, ValueError, TypeError):
        return {}
    if not isinstance(found, dict):
        return {}
    return {k: v for k, v in found.items() if type(k) is str and type(v) is bytes}


def _own(descriptor: int) -> bool:
    getuid = getattr(os, "getuid", None)  # not on Windows, where folders are per user
    return getuid is None or os.fstat(descriptor).st_uid == getuid()


def install() -> None:
    """Give `dataclasses` the kept code, once per process (before rmvdsl's modules
    make their classes: rmvdsl/__init__.py calls it)."""
    if "exec" in vars(dataclasses):
        return  # installed already, or by someone else: leave theirs
    folder = cache_folder()
    kept = _Kept(os.path.join(folder, _FILE_NAME) if folder else None)
    dataclasses.exec = kept.exec  # type: ignore[attr-defined]
    atexit.register(kept.write)
