"""Verdicts that late input made unknown (docs/runtime.md, "Late input").

A message dropped as late would have changed its topic's values from its time on;
the monitor computed that stretch without it. The verdicts whose evaluation reads
that stretch are therefore unknown, not what the monitor said: this module keeps,
per property, the intervals of verdict time affected and cuts the verdict segments
that cross them.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from rmvdsl.runtime.segments import Segment


class Uncertain:
    """One property's closed intervals of verdict time made unknown; an interval
    with no end yet (`None`) lasts until its topic publishes again."""

    def __init__(self) -> None:
        self.intervals: list[list[Any]] = []

    def add(self, low: Fraction, high: Fraction | None) -> list[Any]:
        interval = [low, high]
        self.intervals.append(interval)
        return interval

    def mask(self, segment: Segment) -> list[Segment]:
        """`segment` cut where it crosses an interval: unknown inside, its own
        verdict outside."""
        if not self.intervals or segment[4].startswith("unknown"):
            return [segment]
        pieces = [segment]
        for low, high in sorted(self.intervals, key=lambda i: i[0]):
            pieces = [cut for piece in pieces for cut in _cut(piece, low, high)]
        # Intervals the output has passed can no longer affect it.
        stop = segment[1]
        self.intervals = [i for i in self.intervals if i[1] is None or i[1] >= stop]
        return pieces


def _cut(segment: Segment, low: Any, high: Any) -> list[Segment]:
    start, stop, start_closed, stop_closed, verdict = segment
    outside = _before(stop, stop_closed, low) or _after(start, start_closed, high)
    if outside or verdict.startswith("unknown"):
        return [segment]
    out: list[Segment] = []
    if start < low:
        out.append((start, low, start_closed, False, verdict))
    inside_start, inside_closed = (low, True) if start < low else (start, start_closed)
    if high is None or high >= stop:
        out.append((inside_start, stop, inside_closed, stop_closed, "unknown"))
        return out
    out.append((inside_start, high, inside_closed, True, "unknown"))
    out.append((high, stop, False, stop_closed, verdict))
    return out


def _before(stop: Any, stop_closed: bool, low: Any) -> bool:
    """Whether a segment ending at `stop` ends before the interval from `low`."""
    return stop < low or (stop == low and not stop_closed)


def _after(start: Any, start_closed: bool, high: Any) -> bool:
    """Whether a segment from `start` begins after the interval ending at `high`."""
    return high is not None and (start > high or (start == high and not start_closed))
