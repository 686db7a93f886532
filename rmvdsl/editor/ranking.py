"""What of a long completion list an editor is sent: the names that match the word
being typed, best first, at most `LIMIT`, marked incomplete so the editor asks
again as the word grows (as rust-analyzer and pyright cap theirs). A list of at
most `LIMIT` is sent whole, for the editor to filter as it likes.

A spec of thousands of names would otherwise send thousands of items after every
key: building and serialising them was most of a completion's time on a 2,000-line
spec, and an editor does not show them anyway."""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TypeVar

LIMIT = 200  # items sent when more match the word

_WORD_TAIL = re.compile(r"[A-Za-z0-9_]*\Z")

T = TypeVar("T")


def typed_word(text: str, offset: int) -> str:
    """The part of a name written just before `offset` (maybe empty)."""
    line_start = text.rfind("\n", 0, offset) + 1
    found = _WORD_TAIL.search(text, line_start, offset)
    return found.group() if found else ""


def shortlist(
    items: Sequence[T], labels: Sequence[str], word: str, limit: int = LIMIT
) -> tuple[list[T], bool]:
    """`items` (labelled `labels`) as sent for `word`, at most `limit`, and
    whether the editor must ask again as the word grows (the list was cut). Cut
    lists hold the labels in which the word's letters appear in order, whatever
    their case (what editors match), those starting with the word first, then the
    shorter: of `V1` typed among 2,000 names `V0`..`V1999`, `V1` itself, then
    `V10`..`V19`, then `V100`..."""
    if len(items) <= limit:
        return list(items), False
    wanted = word.lower()
    ranked = []
    for index, (item, label) in enumerate(zip(items, labels, strict=True)):
        folded = label.lower()
        if not _in_order(wanted, folded):
            continue
        ranked.append((not label.startswith(word), not folded.startswith(wanted),
                       len(label), index, item))  # fmt: skip
    ranked.sort(key=lambda entry: entry[:4])
    return [entry[4] for entry in ranked[:limit]], True


def _in_order(letters: str, label: str) -> bool:
    """Every one of `letters` in `label`, in that order (a subsequence)."""
    at = 0
    for letter in letters:
        at = label.find(letter, at) + 1
        if at == 0:
            return False
    return True
