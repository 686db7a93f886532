"""The text between two edits, for a rescan (rmvdsl.grammar.scanner.rescan).

A text edited in two places since its last scan (an editor's keys in two
declarations far apart) is the old text, moved, between them. Scanned again, the
part between took a rescan 30 ms of a 20,805-line file at each key. Here the scan
stops at the first chunk the old scan had too, found by its first line, and takes
the old scan's chunks from there up to the next difference, moved, where it goes
on scanning. The scan's state at a chunk's start is its line alone (brackets reset
there, and lines never continue a string or a comment), so the chunks of an equal
text are equal, up to the last one whose first line the next difference leaves
whole: the rule the scan resumes by after the first edit, too.
"""

from __future__ import annotations

import bisect

# New chunks a rescan finds before it looks for the old text between two edits: an
# edit inside a few declarations meets the unchanged end sooner, and never pays
# for the old chunks' first lines (10 ms for 14,203 chunks).
PATIENCE = 8
_CANDIDATES = 4  # old chunks of the same first line tried, the nearest first

Chunks = tuple[tuple[int, int], ...]  # a scan's: each one's start and first line

# The old chunks by their first line, of the two scans rescans started from last:
# an editor's keys rescan from the same scan until its next check (the edit path
# from its check's, completion from the newest parse's).
_KEPT: list[tuple[str, dict[str, list[int]]]] = []  # by the text (its scan is one)


class Between:
    """The old text's chunks found again in a text edited in several places."""

    def __init__(self, text: str, old_text: str, old: Chunks, starts: list[int]) -> None:
        self.text, self.old_text, self.old, self.starts = text, old_text, old, starts
        self.met = 0  # new chunks met so far

    def moved(self, start: int, line: int) -> list[tuple[int, int]]:
        """The chunks after the new one at `start` (on `line`) up to the last one
        before the next difference, the old ones moved, when the new chunk begins
        a run of the old text that holds at least one more; else none."""
        self.met += 1
        if self.met < PATIENCE:
            return []
        end = self.text.find("\n", start)
        if end < 0:
            return []  # the last line: no chunk after it
        found = _first_lines(self.old, self.old_text).get(self.text[start:end], ())
        expected = start - (len(self.text) - len(self.old_text))
        nearest = sorted(found, key=lambda index: abs(self.starts[index] - expected))
        for index in nearest[:_CANDIDATES]:
            moved = self._run_from(index, start, line)
            if moved:
                return moved
        return []

    def _run_from(self, index: int, start: int, line: int) -> list[tuple[int, int]]:
        """The old chunks after the old one `index` (the new one at `start` on
        `line`, if the text from there is the same), moved, up to the last whose
        first line the next difference leaves whole."""
        old_start = self.starts[index]
        differs = old_start + common_run(self.old_text, old_start, self.text, start)
        last = bisect.bisect_left(self.starts, differs) - 1
        while last > index and not 0 <= self.old_text.find("\n", self.starts[last]) < differs:
            last -= 1
        delta, lines = start - old_start, line - self.old[index][1]
        kept = self.old[index + 1 : last + 1]
        return [(at + delta, at_line + lines) for at, at_line in kept]


def common_run(a: str, i: int, b: str, j: int) -> int:
    """The length of the longest run of `a` from `i` equal to `b` from `j` (slices
    compare in C: a binary search of a few microseconds on a large file)."""
    low, high = 0, min(len(a) - i, len(b) - j)
    while low < high:
        middle = (low + high + 1) // 2
        if a[i + low : i + middle] == b[j + low : j + middle]:
            low = middle
        else:
            high = middle - 1
    return low


def _first_lines(old: Chunks, old_text: str) -> dict[str, list[int]]:
    """The old scan's chunks (their indices) by the text of their first line."""
    for text, kept in list(_KEPT):  # a copy: the edit lane and the event loop both rescan
        if text == old_text:
            return kept
    by_line: dict[str, list[int]] = {}
    find = old_text.find
    for index, (start, _) in enumerate(old):
        end = find("\n", start)
        if end >= 0:
            by_line.setdefault(old_text[start:end], []).append(index)
    _KEPT[:] = [(old_text, by_line), *_KEPT[:1]]
    return by_line
