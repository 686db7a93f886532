"""Three-valued signals in dense time: breakpoints, each with its value at the
point and on the open interval up to the next (docs/semantics.md). Standard
library only."""

from __future__ import annotations

import bisect
from collections.abc import Iterator
from fractions import Fraction
from typing import Any

FALSE, UNKNOWN, TRUE = 0, 1, 2
# `and` and `or` of two values, by table: the loops that combine signals read these
# (a call of min() or max() parses its arguments for keywords, a few hundred
# instructions each: a tenth of the timescales suite's AlwaysBQR evaluation)
AND = ((0, 0, 0), (0, 1, 1), (0, 1, 2))
OR = ((0, 1, 2), (1, 1, 2), (2, 2, 2))
NAMES = {FALSE: "false", UNKNOWN: "unknown", TRUE: "true"}
_INFINITY = float("inf")


_EXACT_HALVES = 2**52  # below this, n + 0.5 is exact as a float


def _mid(a: Any, b: Any) -> Any:
    """A point strictly between a and b, exactly. Midpoints only serve to read a
    value inside an open interval; for integer times a half-integer float is exact
    and compares with ints much faster than a Fraction."""
    if type(a) is int and type(b) is int:
        total = a + b
        if not total & 1:
            return total >> 1
        return total / 2 if -_EXACT_HALVES < total < _EXACT_HALVES else Fraction(total, 2)
    return (a + b) / 2


def _divide(x: Any, y: Any) -> Any:
    """x / y exactly: an int where that is whole (a Fraction equal to an int
    compares with the ints around it many times slower)."""
    if type(x) is float or type(y) is float:
        return plain(Fraction(x) / Fraction(y))  # exact: halves are exact floats
    if type(x) is int and type(y) is int:
        whole, rest = divmod(x, y)
        return whole if rest == 0 else Fraction(x, y)
    return plain(x / y)


def plain(value: Any) -> Any:
    """A whole Fraction as an int: the same number, compared much faster."""
    if type(value) is Fraction and value.denominator == 1:
        return value.numerator
    return value


def pieces(a: Signal, b: Signal, start: Any) -> Iterator[tuple[Any, int, int, int, int]]:
    """One walk over two signals from `start` on: at `start` and at each breakpoint
    of either, the time, a's value there and just after, and b's."""
    a_starts, a_points, a_opens = a.starts, a.points, a.opens
    b_starts, b_points, b_opens = b.starts, b.points, b.opens
    i, j = a.index(start), b.index(start)
    a_count, b_count = len(a_starts), len(b_starts)
    t = start
    while True:
        yield (
            t,
            a_points[i] if a_starts[i] == t else a_opens[i],
            a_opens[i],
            b_points[j] if b_starts[j] == t else b_opens[j],
            b_opens[j],
        )
        a_next = a_starts[i + 1] if i + 1 < a_count else _INFINITY
        b_next = b_starts[j + 1] if j + 1 < b_count else _INFINITY
        t = a_next if a_next < b_next else b_next
        if t == _INFINITY:
            return
        if a_next == t:
            i += 1
        if b_next == t:
            j += 1


class Signal:
    """A three-valued function on [starts[0], infinity): `points[i]` at
    `starts[i]`, `opens[i]` on (starts[i], starts[i+1])."""

    __slots__ = ("opens", "points", "starts")

    def __init__(self, start: Any, value: int) -> None:
        self.starts: list[Any] = [start]
        self.points: list[int] = [value]
        self.opens: list[int] = [value]

    def index(self, t: Any) -> int:
        index = bisect.bisect_right(self.starts, t) - 1
        return index if index > 0 else 0

    def at(self, t: Any) -> int:
        i = self.index(t)
        return self.points[i] if self.starts[i] == t else self.opens[i]

    def right_of(self, t: Any) -> int:
        """The value just after t."""
        return self.opens[self.index(t)]

    def cut(self, t: Any) -> None:
        """Forget the signal from t on (the caller appends from t)."""
        index = bisect.bisect_left(self.starts, t)
        if index == 0:
            self.starts[0] = t
            index = 1
        del self.starts[index:]
        del self.points[index:]
        del self.opens[index:]

    def append(self, t: Any, point: int, after: int) -> None:
        if t == self.starts[-1]:
            self.points[-1], self.opens[-1] = point, after
            if len(self.starts) > 1 and self.opens[-2] == point == after:
                self.starts.pop()
                self.points.pop()
                self.opens.pop()
            return
        if self.opens[-1] == point == after:
            return
        self.starts.append(t)
        self.points.append(point)
        self.opens.append(after)

    def drop_before(self, t: Any) -> None:
        index = bisect.bisect_right(self.starts, t) - 1
        if index > 0:
            del self.starts[:index]
            del self.points[:index]
            del self.opens[:index]

    def between(self, low: Any, high: Any) -> list[Any]:
        """The breakpoints in (low, high)."""
        return self.starts[
            bisect.bisect_right(self.starts, low) : bisect.bisect_left(self.starts, high)
        ]

    def supremum(self, low: Any, high: Any, low_closed: bool, high_closed: bool) -> int:
        """sup over the interval from low to high (each end open or closed)."""
        if high == low:
            return self.at(low)
        i = self.index(low)
        j = bisect.bisect_left(self.starts, high) - 1  # the last breakpoint before high
        value = max(self.opens[i : j + 1]) if j >= i else self.opens[i]
        if j > i:
            value = max(value, max(self.points[i + 1 : j + 1]))
        if low_closed:
            value = max(value, self.at(low))
        if high_closed:
            value = max(value, self.at(high))
        return value

    def infimum(self, low: Any, high: Any, low_closed: bool, high_closed: bool) -> int:
        """inf over the interval from low to high (each end open or closed)."""
        if high < low or (high == low and not (low_closed and high_closed)):
            return TRUE
        if high == low:
            return self.at(low)
        i = self.index(low)
        value = self.opens[i]
        if low_closed:
            value = min(value, self.at(low))
        j = self.index(high)
        for k in range(i + 1, j + 1):
            if self.starts[k] < high:
                value = min(value, self.points[k], self.opens[k])
        if high_closed:
            value = min(value, self.at(high))
        return value
