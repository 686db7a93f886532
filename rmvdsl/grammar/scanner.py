"""A light scan of a .rmv file ahead of the parser.

It finds comments (the formatter and doc comments need them) and the lines where a
top-level declaration starts. The parser parses each declaration on its own, so a
syntax error in one never hides the errors of the next: that is the coarse level
of error recovery; the token-level level is in `parser.py`.
"""

from __future__ import annotations

import bisect
import dataclasses
import re
from collections.abc import Sequence
from dataclasses import dataclass
from operator import attrgetter, itemgetter

from rmvdsl.grammar.moved import Between, common_run

TOP_LEVEL_KEYWORDS = frozenset(
    {
        "system",
        "import",
        "time",
        "database",
        "topic",
        "var",
        "event",
        "alert",
        "transducer",
        "property",
        "whitelist",
        "node",
        "intrusion",
        "ros",
        "messages",
    }
)


@dataclass(frozen=True)
class RawComment:
    start: int
    end: int
    text: str
    own_line: bool  # nothing but blanks before it on its line


@dataclass(frozen=True)
class ScanResult:
    comments: tuple[RawComment, ...]
    # (offset, 1-based line) of each chunk; the first chunk starts at offset 0.
    chunks: tuple[tuple[int, int], ...]


def _leading_word(line: str) -> tuple[str, int]:
    stripped = line.lstrip(" \t")
    indent = len(line) - len(stripped)
    end = 0
    while end < len(stripped) and (stripped[end].isalnum() or stripped[end] == "_"):
        end += 1
    return stripped[:end], indent


def _starts_declaration(line: str, depth: int) -> bool:
    word, indent = _leading_word(line)
    if word not in TOP_LEVEL_KEYWORDS:
        return False
    if word == "time":
        # `time(100ms)` continues a group-by clause; only `time unit` declares.
        rest = line.lstrip(" \t")[4:].lstrip(" \t")
        if not (rest.startswith("unit") and (len(rest) == 4 or not rest[4].isalnum())):
            return False
    # Inside an unclosed block, only an unindented keyword starts a new declaration:
    # a forgotten `}` then costs one error, not the rest of the file.
    return depth == 0 or indent == 0


# What the scan looks at, in one pass over the text (an editor scans the whole file
# at every keystroke; a loop over every character was a seventh of an edit): a line
# opening with a top-level keyword (`\w` is `isalnum()` or `_`, as in
# `_leading_word`), a string (it ends at its line's end, as the grammar's do), a
# comment, and brackets. Lines never continue a string or a comment, so a line's
# start is never inside one.
_TOKENS = re.compile(
    r"(?P<keyword>^[ \t]*(?:" + "|".join(sorted(TOP_LEVEL_KEYWORDS)) + r")(?!\w))"
    r'|"(?:[^"\\\n]|\\[^\n])*"?'
    r"|(?P<comment>//[^\n]*)"
    r"|(?P<open>[{(\[])"
    r"|(?P<close>[})\]])",
    re.MULTILINE,
)


def scan(text: str, before: tuple[str, ScanResult] | None = None) -> ScanResult:
    """The comments and declaration chunks of a text. With `before` (an earlier text
    of the same file and its scan, an editor's), only what an edit changed is
    scanned again: the chunks before it are kept, and the scan stops once it meets
    a chunk of the unchanged end, whose chunks and comments are moved along."""
    if before is None:
        return _scan(text, 0, 1, [], [(0, 1)])
    if before[0] == text:
        return before[1]
    index, unchanged = _resumed(text, *before)
    old = before[1]
    resume, line = old.chunks[index]
    kept = bisect.bisect_left(unchanged.old_comment_starts, resume)
    return _scan(
        text, resume, line, list(old.comments[:kept]), list(old.chunks[: index + 1]), unchanged
    )


@dataclass(frozen=True)
class Rescan:
    """The chunks of a text an edit changed, against its scan before the edit:
    the old scan's chunks before `first` are the new text's, and from `rest` on
    the new text's are the old ones moved by the edit."""

    first: int
    chunks: tuple[tuple[int, int], ...]  # the new text's, from `first` up to `rest`
    rest: int | None  # None: the scan found no chunk of the unchanged end


def rescan(text: str, old_text: str, old: ScanResult) -> Rescan:
    """Only the chunks an edit changed (scan's work without moving the rest): the
    editor's check of a keystroke inside a few declarations (rmvdsl.check.edit).
    Edits in several places: the text between them is the old one moved, and its
    chunks are the old ones moved, not scanned again (rmvdsl.grammar.moved)."""
    index, unchanged = _resumed(text, old_text, old)
    resume, line = old.chunks[index]
    between = Between(text, old_text, old.chunks, unchanged.old_starts)
    stopping = dataclasses.replace(unchanged, join=False, between=between)
    chunks = [(resume, line)]
    while True:
        found = _scan(text, resume, line, [], chunks, stopping)
        if found.chunks[-1] != _JUMPED:
            break
        chunks = list(found.chunks[:-1])
        resume, line = chunks[-1]
    if found.chunks[-1] == _STOPPED:
        rest = unchanged.rest(found.chunks[-2][0])
        assert rest is not None
        return Rescan(index, found.chunks[:-2], rest[0])
    return Rescan(index, found.chunks, None)


def chunk_before(text: str, old_text: str, old: ScanResult, offset: int) -> int:
    """The start of the last chunk of `text` that starts before `offset` (0 when
    none does), from the scan of an earlier text: the chunks rescan finds, and
    those it kept, each read where it now stands, none moved (completion's
    question at each key: moving the rest of a 20,805-line file's chunks was
    4 ms of each request)."""
    if text == old_text:
        return _start_before(old.chunks, offset)
    found = rescan(text, old_text, old)
    if found.rest is not None:  # the unchanged end, moved by the edit
        delta = len(text) - len(old_text)
        index = bisect.bisect_left(old.chunks, (offset - delta,), found.rest)
        if index > found.rest:
            return old.chunks[index - 1][0] + delta
    start = _start_before(found.chunks, offset)
    if found.chunks and found.chunks[0][0] < offset:
        return start
    return _start_before(old.chunks, offset, found.first)


def _start_before(chunks: Sequence[tuple[int, int]], offset: int, end: int | None = None) -> int:
    """The start of the last of `chunks[:end]` that starts before `offset`, or 0."""
    index = bisect.bisect_left(chunks, (offset,), 0, len(chunks) if end is None else end)
    return chunks[index - 1][0] if index else 0


def _resumed(text: str, old_text: str, old: ScanResult) -> tuple[int, _Unchanged]:
    """The old chunk a scan of the new text resumes at (its index), and the
    unchanged end of the text."""
    prefix = common_prefix(old_text, text)
    # The state at a chunk's start is its line alone (brackets reset there), so the
    # scan resumes at the last chunk whose first line the edit left whole.
    starts = list(map(itemgetter(0), old.chunks))
    index = bisect.bisect_right(starts, prefix) - 1
    while index > 0 and not 0 <= old_text.find("\n", starts[index]) < prefix:
        index -= 1
    comment_starts = list(map(attrgetter("start"), old.comments))
    suffix = common_suffix(old_text, text, min(len(old_text), len(text)) - prefix)
    delta = len(text) - len(old_text)
    return index, _Unchanged(len(text) - suffix, delta, old, starts, comment_starts)


@dataclass(frozen=True)
class _Unchanged:
    """The unchanged end of a text an edit changed: from `start` on, the new text
    is the old one moved by `delta`."""

    start: int
    delta: int
    old: ScanResult
    old_starts: list[int]  # of its chunks
    old_comment_starts: list[int]
    join: bool = True  # False: stop there, the old scan's rest not moved (rescan)
    between: Between | None = None  # rescan's: the text between two edits, skipped

    def rest(self, start: int) -> tuple[int, int] | None:
        """Where the old chunk now starting at `start` was (its index) and its line,
        if it is in the unchanged end."""
        if start < self.start:
            return None
        index = bisect.bisect_left(self.old_starts, start - self.delta)
        if index == len(self.old_starts) or self.old_starts[index] != start - self.delta:
            return None
        return index, self.old.chunks[index][1]

    def joined(
        self, comments: list[RawComment], chunks: list[tuple[int, int]], index: int, lines: int
    ) -> ScanResult:
        """The scan so far (ending with the chunk `index` of the old scan, now
        `lines` lines further), followed by the old scan's rest moved along."""
        if not self.join:
            return ScanResult((), (*chunks, _STOPPED))
        delta, old = self.delta, self.old
        start = old.chunks[index][0]
        chunks += [(c + delta, line + lines) for c, line in old.chunks[index + 1 :]]
        first = bisect.bisect_left(self.old_comment_starts, start)
        comments += [
            RawComment(c.start + delta, c.end + delta, c.text, c.own_line)
            for c in old.comments[first:]
        ]
        return ScanResult(tuple(comments), tuple(chunks))


_STOPPED = (-1, -1)  # ends a rescan's chunks when it met the unchanged end
_JUMPED = (-2, -2)  # ends them when it skipped the text between two edits


def _scan(
    text: str,
    start: int,
    line_number: int,
    comments: list[RawComment],
    chunks: list[tuple[int, int]],
    unchanged: _Unchanged | None = None,
) -> ScanResult:
    """Scan from `start`, a chunk's start (or 0) on line `line_number`, the
    comments and chunks before it found already; stop at the unchanged end."""
    depth = 0
    counted = start  # newlines counted up to `counted`
    for match in _TOKENS.finditer(text, start):
        kind, start = match.lastgroup, match.start()
        if kind == "open":
            depth += 1
        elif kind == "close":
            depth = max(0, depth - 1)
        elif kind == "keyword":
            if _declares(text, match, depth):
                depth = 0
                if start != chunks[-1][0]:
                    line_number += text.count("\n", counted, start)
                    counted = start
                    chunks.append((start, line_number))
                    rest = unchanged.rest(start) if unchanged is not None else None
                    if rest is not None:
                        assert unchanged is not None
                        return unchanged.joined(comments, chunks, rest[0], line_number - rest[1])
                    if unchanged is not None and unchanged.between is not None:
                        moved = unchanged.between.moved(start, line_number)
                        if moved:
                            return ScanResult((), (*chunks, *moved, _JUMPED))
        elif kind == "comment":
            line_start = text.rfind("\n", 0, start) + 1
            own_line = not text[line_start:start].strip()
            found = match.group().rstrip("\r")
            comments.append(RawComment(start, start + len(found), found, own_line))
    return ScanResult(tuple(comments), tuple(chunks))


def common_prefix(a: str, b: str) -> int:
    """The length of the longest common prefix."""
    return common_run(a, 0, b, 0)


def common_suffix(a: str, b: str, most: int) -> int:
    """The length of the longest common suffix, at most `most`."""
    low, high = 0, most
    while low < high:
        middle = (low + high + 1) // 2
        if a[len(a) - middle : len(a) - low] == b[len(b) - middle : len(b) - low]:
            low = middle
        else:
            high = middle - 1
    return low


def _declares(text: str, keyword: re.Match[str], depth: int) -> bool:
    """Whether the line of a leading keyword starts a declaration."""
    if depth == 0 and not keyword.group().endswith("time"):
        return True  # the common case, without reading the line again
    start = keyword.start()
    end = text.find("\n", start)
    return _starts_declaration(text[start:] if end == -1 else text[start:end], depth)
