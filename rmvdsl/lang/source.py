"""Source files and spans.

A span is two character offsets into one source file. Lines and columns are
computed only when a diagnostic is shown, from a line table built once per file,
so that building the AST stays cheap.
"""

from __future__ import annotations

import bisect
import itertools
from collections.abc import Iterator
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Span:
    """Half-open range [start, end) of character offsets in the file `path`."""

    path: str
    start: int
    end: int

    def cover(self, other: Span) -> Span:
        """The smallest span holding both spans (they must share a file)."""
        return Span(self.path, min(self.start, other.start), max(self.end, other.end))

    def shifted(self, delta: int) -> Span:
        # Without __init__ (frozen fields are set one by one through object's
        # __setattr__): an editor moves most of a file's spans at each keystroke.
        moved = object.__new__(Span)
        moved.__dict__.update(path=self.path, start=self.start + delta, end=self.end + delta)
        return moved


NO_SPAN = Span("<none>", 0, 0)


@dataclass(frozen=True)
class Position:
    """1-based line and column (columns count characters, not bytes)."""

    line: int
    column: int


@dataclass
class SourceFile:
    path: str
    text: str
    _line_starts: list[int] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        # Each line's start: the running sum of the lengths of the lines before it,
        # newlines included (in C: an editor builds it at every keystroke).
        lengths = map((1).__add__, map(len, self.text.split("\n")))
        starts = list(itertools.accumulate(lengths, initial=0))
        starts.pop()  # the end of the last line
        self._line_starts = starts

    @property
    def line_count(self) -> int:
        return len(self._line_starts)

    def position(self, offset: int) -> Position:
        offset = max(0, min(offset, len(self.text)))
        line_index = bisect.bisect_right(self._line_starts, offset) - 1
        return Position(line_index + 1, offset - self._line_starts[line_index] + 1)

    def offset(self, line: int, column: int) -> int:
        """Offset of a 1-based line and column, clamped to the file."""
        line = max(1, min(line, len(self._line_starts)))
        return min(self._line_starts[line - 1] + column - 1, len(self.text))

    def line_text(self, line: int) -> str:
        start = self._line_starts[line - 1]
        end = self._line_starts[line] - 1 if line < len(self._line_starts) else len(self.text)
        return self.text[start:end].rstrip("\r")

    def line_start(self, line: int) -> int:
        return self._line_starts[line - 1]

    def span(self, start: int, end: int) -> Span:
        return Span(self.path, start, end)


class SourceMap:
    """All files read for one check, by path."""

    def __init__(self) -> None:
        self._files: dict[str, SourceFile] = {}

    def add(self, source: SourceFile) -> SourceFile:
        self._files[source.path] = source
        return source

    def get(self, path: str) -> SourceFile | None:
        return self._files.get(path)

    def __iter__(self) -> Iterator[SourceFile]:
        return iter(self._files.values())
