"""A bounded map for what an editor keeps between keystrokes: parsed declaration
chunks (rmvdsl.grammar.parser), each file's last scan, each declaration's findings
(rmvdsl.check.memo).

Safe across threads (an editor's fast and solver checks run at once): reads take no
lock (a dict's get is atomic), writes take one. The oldest entry leaves first; an
entry put again is the newest. `fit` grows the bound to twice a count (the chunks
of a file, the declarations of a check), so a large spec never evicts its own
entries on every keystroke.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

Key = TypeVar("Key", bound=Hashable)
Value = TypeVar("Value")


class Bounded(Generic[Key, Value]):
    def __init__(self, size: int) -> None:
        self._entries: dict[Key, Value] = {}
        self._size = size
        self._lock = threading.Lock()

    def get(self, key: Key) -> Value | None:
        return self._entries.get(key)

    def reader(self) -> Callable[[Key], Value | None]:
        """`get`, as the dict's own method: a loop over thousands of keys calls it
        without a Python call each."""
        return self._entries.get

    def put(self, key: Key, value: Value) -> None:
        with self._lock:
            entries = self._entries
            entries.pop(key, None)
            entries[key] = value
            while len(entries) > self._size:
                del entries[next(iter(entries))]

    def fit(self, count: int) -> None:
        with self._lock:
            self._size = max(self._size, 2 * count)

    def __len__(self) -> int:
        return len(self._entries)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()
