"""Durations and their comparisons: `duration[T](f)` as an interval of possible
values (unknown input leaves a range), arithmetic over such terms, and comparisons
that are true or false only when every value in the ranges agrees."""

from __future__ import annotations

import itertools
from typing import Any

from rmvdsl.runtime.signal import _INFINITY, FALSE, TRUE, UNKNOWN, Signal, _divide
from rmvdsl.runtime.temporal import Evaluated, Node


class Compare(Evaluated):
    """A comparison of terms: constants, durations, sums, and products by a
    constant. A duration is an interval [surely, possibly]; between breakpoints
    terms are linear in t, so the comparison changes only at breakpoints and where
    two linear pieces cross, both computed exactly."""

    def __init__(self, op: str, left: Any, right: Any) -> None:
        super().__init__()
        self.op, self.left, self.right = op, left, right
        self.bodies = _term_nodes(left) + _term_nodes(right)
        self.integrals: dict[int, Integral] = {}  # during an update: id(signal) ->
        self.future = max([window + body.future for window, body in self.bodies] or [0])
        self.past = max([body.past for _, body in self.bodies] or [0])
        self.reach = max([body.reach for _, body in self.bodies] or [0])

    def children(self) -> list[Node]:
        return [body for _, body in self.bodies]

    def update(self, start: Any) -> None:
        """Each duration read during the update is two lookups in its body's
        integral, built once: reading it by walking the window made an update cost
        the square of the changes inside the window (a flood of changes within a
        4 s window took minutes)."""
        self.integrals = {id(body.signal): Integral(body.signal) for _, body in self.bodies}
        try:
            super().update(start)
        finally:
            self.integrals = {}

    def breakpoints(self, start: Any) -> set[Any]:
        found = set()
        for window, body in self.bodies:
            for point in body.signal.between(start - window - 1, _INFINITY):
                found.add(point)
                found.add(point - window)
        ordered = sorted(p for p in found if p > start)
        ends = [start, *ordered, (ordered[-1] if ordered else start) + self.future + 1]
        # both sides at each end once (a pair's end is the next pair's start)
        sides = [(self._term(self.left, t), self._term(self.right, t)) for t in ends]
        for (a, at_a), (b, at_b) in itertools.pairwise(zip(ends, sides, strict=True)):
            found.update(_crossings(a, b, at_a, at_b))
        return found

    def value_at(self, t: Any) -> int:
        return compare(self.op, self._term(self.left, t), self._term(self.right, t))

    def _term(self, term: Any, t: Any) -> tuple[Any, Any]:
        kind = term[0]
        if kind == "num":
            return term[1], term[1]
        if kind == "dur":
            signal = term[2].signal
            integral = self.integrals.get(id(signal))
            if integral is None:  # read outside an update
                return duration(signal, t, t + term[1])
            return integral.duration(t, t + term[1])
        return arithmetic(kind, self._term(term[1], t), self._term(term[2], t))


def _crossings(a: Any, b: Any, at_a: Any, at_b: Any) -> list[Any]:
    """Where, strictly between a and b, the bounds of the two sides (linear there)
    cross: `at_a` and `at_b` are both sides' intervals at a and at b."""
    (la, ha), (lb, hb) = at_a
    (la2, ha2), (lb2, hb2) = at_b
    found = []
    for f_a, f_b in ((ha - lb, ha2 - lb2), (la - hb, la2 - hb2)):
        if (f_a < 0 < f_b) or (f_b < 0 < f_a):
            found.append(a + _divide((b - a) * (0 - f_a), f_b - f_a))
    return found


def compare(op: str, left: tuple[Any, Any], right: tuple[Any, Any]) -> int:
    """A comparison of two interval-valued terms, three-valued (docs/semantics.md)."""
    if op == "<":
        return _less(left, right)
    if op == ">":
        return _less(right, left)
    if op == "<=":
        return 2 - _less(right, left)
    if op == ">=":
        return 2 - _less(left, right)
    equal = min(2 - _less(left, right), 2 - _less(right, left))
    return equal if op == "==" else 2 - equal


def _less(a: tuple[Any, Any], b: tuple[Any, Any]) -> int:
    if a[1] < b[0]:
        return TRUE
    if a[0] >= b[1]:
        return FALSE
    return UNKNOWN


def _term_nodes(term: Any) -> list[tuple[Any, Node]]:
    if term[0] == "dur":
        return [(term[1], term[2])]
    if term[0] == "num":
        return []
    return _term_nodes(term[1]) + _term_nodes(term[2])


def arithmetic(kind: str, left: tuple[Any, Any], right: tuple[Any, Any]) -> tuple[Any, Any]:
    """`add`, `sub` or `mul` of two intervals (docs/semantics.md)."""
    if kind == "add":
        return left[0] + right[0], left[1] + right[1]
    if kind == "sub":
        return left[0] - right[1], left[1] - right[0]
    products = [x * y for x in left for y in right]
    return min(products), max(products)


class Integral:
    """How long a signal is surely and possibly true from its first breakpoint up
    to each breakpoint: the duration over any window is then a difference, exact
    (times are ints, Fractions or exact half-integer floats)."""

    __slots__ = ("possibly", "signal", "surely")

    def __init__(self, signal: Signal) -> None:
        self.signal = signal
        starts, opens = signal.starts, signal.opens
        self.surely: list[Any] = [0]
        self.possibly: list[Any] = [0]
        surely = possibly = 0
        for i in range(len(starts) - 1):
            length = starts[i + 1] - starts[i]
            if opens[i] == TRUE:
                surely += length
                possibly += length
            elif opens[i] == UNKNOWN:
                possibly += length
            self.surely.append(surely)
            self.possibly.append(possibly)

    def duration(self, low: Any, high: Any) -> tuple[Any, Any]:
        """What `duration(signal, low, high)` gives, in two lookups."""
        if not low < high:
            return 0, 0
        signal = self.signal
        i, j = signal.index(low), signal.index(high)
        opens, starts = signal.opens, signal.starts
        surely = self.surely[j] - self.surely[i]
        possibly = self.possibly[j] - self.possibly[i]
        if opens[j] != FALSE:  # the part of high's segment before high
            inside = high - starts[j]
            possibly += inside
            if opens[j] == TRUE:
                surely += inside
        if opens[i] != FALSE:  # less the part of low's segment before low
            outside = low - starts[i]
            possibly -= outside
            if opens[i] == TRUE:
                surely -= outside
        return surely, possibly


def duration(signal: Signal, low: Any, high: Any) -> tuple[Any, Any]:
    """How long the signal is true in [low, high): surely, possibly."""
    surely = possibly = 0
    starts, opens = signal.starts, signal.opens
    i = signal.index(low)
    cursor = low
    while cursor < high:
        end = starts[i + 1] if i + 1 < len(starts) and starts[i + 1] < high else high
        if opens[i] == TRUE:
            surely += end - cursor
            possibly += end - cursor
        elif opens[i] == UNKNOWN:
            possibly += end - cursor
        cursor = end
        i += 1
    return surely, possibly
