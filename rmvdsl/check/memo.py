"""What checking each declaration found, remembered by the declaration's text, so an
editor's next check reuses it (the names and types stages, when a check is asked to
be incremental).

An edit changes one declaration; the stages used to visit all of them at every
keystroke. A declaration's findings are kept by its file, its text and the spec's
time unit, with what it looked up outside itself (the kind of each name it resolved,
the type of each name it read, the message definitions a variable's path crossed).
They are reused only while every such lookup still gives the same answer, and only
when it had no finding to report: a clean declaration's results are references and
types, and a diagnostic's message could read anything. tests/test_incremental.py
checks every reused answer against a check from scratch.
"""

from __future__ import annotations

import threading
from typing import Generic, TypeVar

from rmvdsl.check.model import Model
from rmvdsl.grammar import ast

Value = TypeVar("Value")

# The file, the declaration's text, the spec's time unit (which gives bare numbers
# in formulas a unit).
Key = tuple[str, str, str | None]


class Memo(Generic[Value]):
    """A bounded store, safe across threads (an editor's fast and solver checks run
    at once): reads take no lock (a dict's get is atomic), the oldest entry leaves
    first. It grows to twice the most declarations of one check, so a large spec
    does not evict its own entries."""

    def __init__(self, size: int = 50_000) -> None:
        self._entries: dict[Key, Value] = {}
        self._size = size
        self._lock = threading.Lock()

    def get(self, key: Key) -> Value | None:
        return self._entries.get(key)

    def put(self, key: Key, value: Value) -> None:
        with self._lock:
            entries = self._entries
            entries.pop(key, None)  # a renewed entry is the newest
            entries[key] = value
            while len(entries) > self._size:
                del entries[next(iter(entries))]

    def fit(self, declarations: int) -> None:
        with self._lock:
            self._size = max(self._size, 2 * declarations)

    def __len__(self) -> int:
        return len(self._entries)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()


def declaration_key(model: Model, decl: ast.Node) -> Key | None:
    """The key of a declaration: its file, its text, the time unit; None for one
    with a syntax error (its tree may be partial: it is checked each time)."""
    span = decl.span
    source = model.sources.get(span.path)
    if source is None or (model.damaged_ranges.get(span.path) and model.in_damaged(span)):
        return None
    return (span.path, source.text[span.start : span.end], model.time_unit)
