"""Verdict segments: a verdict over an interval of time, and the one rule that
joins two into one (the monitor, the runtime's records, `merge` and the reference
evaluator all use it)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from typing import Any

Segment = tuple[Any, Any, bool, bool, str]  # start, end, start closed, end closed, value


def continues(earlier: Sequence[Any], later: Sequence[Any]) -> bool:
    """Whether `later` extends `earlier` into one segment: the same verdict, and it
    starts where `earlier` ends with that point covered by one of them. The one rule
    of joining segments: the monitor, the runtime's records, `merge` and the
    reference evaluator all use it."""
    return earlier[4] == later[4] and earlier[1] == later[0] and bool(earlier[3] or later[2])


def extended(earlier: Segment, later: Segment) -> Segment:
    return (earlier[0], later[1], earlier[2], later[3], earlier[4])


def merge(segments: Iterable[Segment]) -> list[Segment]:
    """Join adjacent segments of the same value."""
    return list(merged(segments))


def merged(segments: Iterable[Segment]) -> Iterator[Segment]:
    """`merge` as the segments come: each is given once the next does not extend it."""
    pending: Segment | None = None
    for segment in segments:
        if pending is not None and continues(pending, segment):
            pending = extended(pending, segment)
            continue
        if pending is not None:
            yield pending
        pending = segment
    if pending is not None:
        yield pending


def verdict_at(segments: Iterable[Segment], t: Any) -> str:
    """The verdict the segments give at time t ("unknown" where none covers it)."""
    for segment in segments:
        if contains(segment, t):
            return str(segment[4])
    return "unknown"


def contains(segment: Segment, t: Any) -> bool:
    a, b, a_closed, b_closed, _ = segment
    return bool((a < t or (a == t and a_closed)) and (t < b or (t == b and b_closed)))
