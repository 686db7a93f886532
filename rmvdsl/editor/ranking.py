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
from itertools import compress, filterfalse, repeat
from typing import NamedTuple, TypeVar

LIMIT = 200  # items sent when more match the word

_WORD_TAIL = re.compile(r"[A-Za-z0-9_]*\Z")

T = TypeVar("T")


def typed_word(text: str, offset: int) -> str:
    """The part of a name written just before `offset` (maybe empty)."""
    line_start = text.rfind("\n", 0, offset) + 1
    found = _WORD_TAIL.search(text, line_start, offset)
    return found.group() if found else ""


class Labels(NamedTuple):
    """Labels as shortlist reads them: worked out once for a list of names asked
    for at many keys (at 20,805 lines, 9,000 names: 2 ms of each request)."""

    text: list[str]
    folded: list[str]  # lower case
    lengths: list[int]


def labels_of(labels: Sequence[str]) -> Labels:
    return Labels(list(labels), list(map(str.lower, labels)), list(map(len, labels)))


def joined(first: Labels, then: Labels) -> Labels:
    """The labels of two lists, one after the other."""
    return Labels(first.text + then.text, first.folded + then.folded, first.lengths + then.lengths)


def shortlist(
    items: Sequence[T], labels: Labels | Sequence[str], word: str, limit: int = LIMIT
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
    # Each pass over the names in C (map, compress): a pass of Python's per name
    # was most of a request in a spec of 10,000 names.
    if not isinstance(labels, Labels):
        labels = labels_of(labels)
    labels, folded, lengths = labels
    everyone = range(len(labels))
    if wanted:  # its letters in order: a regex of each after the one before
        letters = re.compile(".*?".join(map(re.escape, wanted)), re.DOTALL).search
        matched = list(compress(everyone, map(letters, folded)))
    else:
        matched = list(everyone)
    # The order of (not starting as typed, not starting in any case, length,
    # index): three groups, each in order of length (a stable sort keeps the
    # index order of equal lengths).
    as_typed = list(map(str.startswith, labels, repeat(word)))
    any_case = list(map(str.startswith, folded, repeat(wanted)))
    first = list(compress(matched, map(as_typed.__getitem__, matched)))
    rest = list(filterfalse(as_typed.__getitem__, matched))
    second = list(compress(rest, map(any_case.__getitem__, rest)))
    third = list(filterfalse(any_case.__getitem__, rest))
    ranked: list[int] = []
    for group in (first, second, third):
        ranked += sorted(group, key=lengths.__getitem__)
        if len(ranked) >= limit:
            break
    return [items[i] for i in ranked[:limit]], True
