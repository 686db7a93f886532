"""An online monitor for RMTLD3, exact in dense time (docs/semantics.md).

This module uses the Python standard library only: generated ROS nodes embed it.
Formulas come as nested tuples (`rmvdsl.logic.compile` makes them):

    ("prop", name)  ("const", bool)  ("not", f)  ("and", f, g)  ("or", f, g)
    ("until", op, T, f, g)  ("since", op, T, f, g)        op: "<", "<=", "="
    ("cmp", op, a, b)   op: "<", "<=", ">", ">=", "==", "!="
    terms: ("num", v)  ("dur", T, f)  ("add", a, b)  ("sub", a, b)  ("mul", a, b)

Truth values are 0 (false), 1 (unknown), 2 (true): `and` is min, `or` is max,
`not` is 2 - v. Each subformula's value over time is a Signal: breakpoints, each
with its value at the point and on the open interval up to the next one (bounded
operators make isolated points: `always[<1] a` over a on [0, 1) holds at 0 only).
The last interval runs forever (for atoms: unknown after the newest input).

When input extends the trace, a node recomputes only from `newest input - its
future horizon` on: earlier values cannot change, and by monotonicity a true or
false value never changes at all. Memory is the breakpoints inside the horizon.
Times are int, Fraction or float; with int or Fraction everything is exact.
"""

from __future__ import annotations

import bisect
import heapq
import itertools
from abc import ABC, abstractmethod
from collections.abc import Iterable, Iterator, Sequence
from fractions import Fraction
from typing import Any, NamedTuple

FALSE, UNKNOWN, TRUE = 0, 1, 2
NAMES = {FALSE: "false", UNKNOWN: "unknown", TRUE: "true"}
_INFINITY = float("inf")
_NO_PULSES: frozenset[str] = frozenset()
BATCH = 256  # changes recomputed together once the input spans the horizon
SPARSE_HORIZONS = 32  # or once it spans this many horizons


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
    if type(x) is float or type(y) is float:
        return Fraction(x) / Fraction(y)  # exact: halves are exact floats
    if type(x) is int and type(y) is int:
        return Fraction(x, y)
    return x / y


def _plain(value: Any) -> Any:
    """A whole Fraction as an int: the same number, compared much faster."""
    if type(value) is Fraction and value.denominator == 1:
        return value.numerator
    return value


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


class Node:
    future: Any = 0  # how far the subformula looks ahead of the time it is evaluated at
    past: Any = 0

    def __init__(self) -> None:
        self.signal = Signal(0, UNKNOWN)

    def reset(self, start: Any) -> None:
        self.signal = Signal(start, UNKNOWN)

    def update(self, start: Any) -> None:
        """Recompute the signal on [start, infinity) from the children's."""

    def children(self) -> list[Node]:
        return []


class Const(Node):
    def __init__(self, value: int) -> None:
        super().__init__()
        self.value = value

    def reset(self, start: Any) -> None:
        self.signal = Signal(start, self.value)


class Prop(Node):
    """Written by the monitor from the input."""


class Not(Node):
    def __init__(self, child: Node) -> None:
        super().__init__()
        self.child = child
        self.future, self.past = child.future, child.past

    def children(self) -> list[Node]:
        return [self.child]

    def update(self, start: Any) -> None:
        source, signal = self.child.signal, self.signal
        signal.cut(start)
        i = source.index(start)
        signal.append(start, 2 - source.at(start), 2 - source.opens[i])
        for k in range(i + 1, len(source.starts)):
            signal.append(source.starts[k], 2 - source.points[k], 2 - source.opens[k])


class Binary(Node):
    def __init__(self, op: str, left: Node, right: Node) -> None:
        super().__init__()
        self.combine = min if op == "and" else max
        self.left, self.right = left, right
        self.future = max(left.future, right.future)
        self.past = max(left.past, right.past)

    def children(self) -> list[Node]:
        return [self.left, self.right]

    def update(self, start: Any) -> None:
        """One merge walk over both children's breakpoints from `start` on."""
        a, b, signal, combine = self.left.signal, self.right.signal, self.signal, self.combine
        signal.cut(start)
        a_starts, a_points, a_opens = a.starts, a.points, a.opens
        b_starts, b_points, b_opens = b.starts, b.points, b.opens
        i, j = a.index(start), b.index(start)
        a_point = a_points[i] if a_starts[i] == start else a_opens[i]
        b_point = b_points[j] if b_starts[j] == start else b_opens[j]
        signal.append(start, combine(a_point, b_point), combine(a_opens[i], b_opens[j]))
        i, j = i + 1, j + 1
        a_count, b_count = len(a_starts), len(b_starts)
        while i < a_count or j < b_count:
            a_next = a_starts[i] if i < a_count else _INFINITY
            b_next = b_starts[j] if j < b_count else _INFINITY
            t = a_next if a_next < b_next else b_next
            if a_next == t:
                a_point, a_open = a_points[i], a_opens[i]
                i += 1
            else:
                a_point = a_open = a_opens[i - 1]
            if b_next == t:
                b_point, b_open = b_points[j], b_opens[j]
                j += 1
            else:
                b_point = b_open = b_opens[j - 1]
            signal.append(t, combine(a_point, b_point), combine(a_open, b_open))


class Evaluated(Node, ABC):
    """A node whose value is computed pointwise, at every point where it can change
    and at one point of each open interval between (exact for these signals)."""

    @abstractmethod
    def breakpoints(self, start: Any) -> set[Any]:
        """Every time after `start` where the value may change."""

    @abstractmethod
    def value_at(self, t: Any) -> int:
        """The value at time t, read from the children's signals."""

    def update(self, start: Any) -> None:
        points = sorted(p for p in self.breakpoints(start) if p > start)
        signal = self.signal
        signal.cut(start)
        ends = [*points, (points[-1] if points else start) + self.future + self.past + 1]
        previous = start
        for point in ends:
            after = self.value_at(_mid(previous, point))
            signal.append(previous, self.value_at(previous), after)
            previous = point


class Temporal(Evaluated):
    """Until (future) and since (past), bounded by `< T`, `<= T` or `= T`."""

    origin: Any = 0  # time starts here: since never looks before it

    def __init__(self, kind: str, op: str, bound: Any, left: Node, right: Node) -> None:
        super().__init__()
        self.kind, self.op, self.bound = kind, op, bound
        self.left, self.right = left, right
        future = max(left.future, right.future)
        past = max(left.past, right.past)
        if kind == "until":
            self.future, self.past = future + bound, past
        else:
            self.future, self.past = future, past + bound
        # `eventually` and `once` (true on the left): the value is the sup of psi
        # over the window, read from the segment lists in one slice.
        self.plain = isinstance(left, Const) and left.value == TRUE

    def children(self) -> list[Node]:
        return [self.left, self.right]

    def breakpoints(self, start: Any) -> set[Any]:
        shift = -self.bound if self.kind == "until" else self.bound
        found = set()
        for child in (self.left.signal, self.right.signal):
            for point in child.between(start - self.bound - 1, _INFINITY):
                found.add(point)
                found.add(point + shift)
        if self.kind == "since":
            found.add(self.origin + self.bound)
        return found

    def update(self, start: Any) -> None:
        if self.plain and self.op != "=" and (self.op == "<=" or self.bound > 0):
            self._dilate(start)
        else:
            super().update(start)

    def _dilate(self, start: Any) -> None:
        """`eventually` and `once` in one pass: each piece of psi (a point or an open
        interval) makes the result at least its value over the interval of t whose
        window meets it; the result is the highest level covering t. The pieces'
        intervals have ordered ends, so each level's union is one merge."""
        psi, bound, closed = self.right.signal, self.bound, self.op == "<="
        past = self.kind == "since"
        starts, points, opens = psi.starts, psi.points, psi.opens
        count = len(starts)
        levels: tuple[list[list[Any]], list[list[Any]]] = ([], [])  # value >= 1, == 2
        for k in range(psi.index(start - bound if past else start), count):
            at = starts[k]
            following = starts[k + 1] if k + 1 < count else _INFINITY
            if points[k]:
                if past:
                    _cover(levels, points[k], at, True, at + bound, closed)
                else:
                    _cover(levels, points[k], at - bound, closed, at, True)
            if opens[k]:
                if past:
                    _cover(levels, opens[k], at, False, following + bound, False)
                else:
                    _cover(levels, opens[k], at - bound, False, following, False)
        signal = self.signal
        signal.cut(start)
        ends = {start}
        for level in levels:
            for low, _, high, _ in level:
                if low > start:
                    ends.add(low)
                if start < high < _INFINITY:
                    ends.add(high)
        ones, twos = levels
        one = two = 0  # the first interval of each level not yet behind t
        for t in sorted(ends):
            one, one_point, one_after = _covers(ones, one, t)
            two, two_point, two_after = _covers(twos, two, t)
            signal.append(t, one_point + two_point, one_after + two_after)

    def value_at(self, t: Any) -> int:
        if self.op == "<" and self.bound <= 0:
            return FALSE  # an empty window: no t' at all
        if self.plain:
            return self._sup(t)
        return self._until(t) if self.kind == "until" else self._since(t)

    def _sup(self, t: Any) -> int:
        """sup of psi over the window: `eventually` (until) or `once` (since)."""
        psi, op, bound = self.right.signal, self.op, self.bound
        if self.kind == "until":
            if op == "=":
                return psi.at(t + bound)
            return psi.supremum(t, t + bound, True, op == "<=")
        begin = t - bound
        if op == "=":
            return FALSE if begin < self.origin else psi.at(begin)
        if begin < self.origin:
            return psi.supremum(self.origin, t, True, True)
        return psi.supremum(begin, t, op == "<=", True)

    def _until(self, t: Any) -> int:
        """sup over t' in the window of min(psi(t'), inf of phi over [t, t'))."""
        phi, psi, op = self.left.signal, self.right.signal, self.op
        end = t + self.bound
        if op == "=":
            return min(psi.at(end), phi.infimum(t, end, True, False))
        best = FALSE
        prefix = TRUE  # inf of phi over [t, cursor)
        cursor = t
        for point in [*sorted(psi.between(t, end) + phi.between(t, end)), end]:
            best = max(best, min(psi.at(cursor), prefix))  # t' = cursor
            prefix = min(prefix, phi.at(cursor))
            if cursor < point:  # t' in (cursor, point): phi also holds on (cursor, t')
                inside = phi.right_of(cursor)
                prefix = min(prefix, inside)
                best = max(best, min(psi.right_of(cursor), prefix))
            if best == TRUE:
                return TRUE
            cursor = point
        if op == "<=" or end == t:
            best = max(best, min(psi.at(end), prefix)) if op == "<=" else best
        return best

    def _since(self, t: Any) -> int:
        """sup over t' in the window, from the origin on, of
        min(psi(t'), inf of phi over (t', t])."""
        phi, psi, op = self.left.signal, self.right.signal, self.op
        begin = t - self.bound
        if op == "=":
            if begin < self.origin:
                return FALSE
            return min(psi.at(begin), phi.infimum(begin, t, False, True))
        low, low_closed = (begin, op == "<=") if begin > self.origin else (self.origin, True)
        if low > t or (low == t and not low_closed):
            return FALSE
        best = FALSE
        suffix = TRUE  # inf of phi over (cursor, t]
        cursor = t
        for point in [
            *sorted(psi.between(low, t) + phi.between(low, t), reverse=True),
            low,
        ]:
            if cursor > low or low_closed:
                best = max(best, min(psi.at(cursor), suffix))  # t' = cursor
            suffix = min(suffix, phi.at(cursor))
            if point < cursor:  # t' in (point, cursor)
                suffix = min(suffix, phi.right_of(point))
                best = max(best, min(psi.right_of(point), suffix))
            if best == TRUE:
                return TRUE
            cursor = point
        if low_closed and low < t:
            best = max(best, min(psi.at(low), suffix))
        return best


def _cover(
    levels: tuple[list[list[Any]], list[list[Any]]],
    value: int,
    low: Any,
    low_closed: bool,
    high: Any,
    high_closed: bool,
) -> None:
    """Add an interval where the result is at least `value` (1 or 2) to the union of
    each level it reaches. Intervals come with ordered lows and highs."""
    for intervals in levels[:value]:
        if intervals:
            last = intervals[-1]
            if low < last[2] or (low == last[2] and (low_closed or last[3])):
                if high > last[2]:
                    last[2], last[3] = high, high_closed
                elif high == last[2]:
                    last[3] = last[3] or high_closed
                continue
        intervals.append([low, low_closed, high, high_closed])


def _covers(intervals: list[list[Any]], k: int, t: Any) -> tuple[int, int, int]:
    """Whether the union covers t (1 or 0) and the instants just after t, moving the
    cursor k past the intervals that end before; times come in increasing order."""
    count = len(intervals)
    while k < count and (intervals[k][2] < t or (intervals[k][2] == t and not intervals[k][3])):
        k += 1
    low = intervals[k] if k < count else None
    point = int(low is not None and (low[0] < t or (low[0] == t and low[1])))
    while k < count and intervals[k][2] <= t:
        k += 1
    after = int(k < count and intervals[k][0] <= t)
    return k, point, after


class Compare(Evaluated):
    """A comparison of terms: constants, durations, sums, and products by a
    constant. A duration is an interval [surely, possibly]; between breakpoints
    terms are linear in t, so the comparison changes only at breakpoints and where
    two linear pieces cross, both computed exactly."""

    def __init__(self, op: str, left: Any, right: Any) -> None:
        super().__init__()
        self.op, self.left, self.right = op, left, right
        self.bodies = _term_nodes(left) + _term_nodes(right)
        self.future = max([window + body.future for window, body in self.bodies] or [0])
        self.past = max([body.past for _, body in self.bodies] or [0])

    def children(self) -> list[Node]:
        return [body for _, body in self.bodies]

    def breakpoints(self, start: Any) -> set[Any]:
        found = set()
        for window, body in self.bodies:
            for point in body.signal.between(start - window - 1, _INFINITY):
                found.add(point)
                found.add(point - window)
        ordered = sorted(p for p in found if p > start)
        ends = [start, *ordered, (ordered[-1] if ordered else start) + self.future + 1]
        for a, b in itertools.pairwise(ends):
            found.update(self._crossings(a, b))
        return found

    def _crossings(self, a: Any, b: Any) -> list[Any]:
        (la, ha), (lb, hb) = _term(self.left, a), _term(self.right, a)
        (la2, ha2), (lb2, hb2) = _term(self.left, b), _term(self.right, b)
        found = []
        for f_a, f_b in ((ha - lb, ha2 - lb2), (la - hb, la2 - hb2)):
            if (f_a < 0 < f_b) or (f_b < 0 < f_a):
                found.append(a + _divide((b - a) * (0 - f_a), f_b - f_a))
        return found

    def value_at(self, t: Any) -> int:
        return compare(self.op, _term(self.left, t), _term(self.right, t))


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


def _term(term: Any, t: Any) -> tuple[Any, Any]:
    kind = term[0]
    if kind == "num":
        return term[1], term[1]
    if kind == "dur":
        return duration(term[2].signal, t, t + term[1])
    return arithmetic(kind, _term(term[1], t), _term(term[2], t))


def arithmetic(kind: str, left: tuple[Any, Any], right: tuple[Any, Any]) -> tuple[Any, Any]:
    """`add`, `sub` or `mul` of two intervals (docs/semantics.md)."""
    if kind == "add":
        return left[0] + right[0], left[1] + right[1]
    if kind == "sub":
        return left[0] - right[1], left[1] - right[0]
    products = [x * y for x in left for y in right]
    return min(products), max(products)


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


def build(formula: Any, props: dict[str, Prop]) -> Node:
    kind = formula[0]
    if kind == "prop":
        return props.setdefault(formula[1], Prop())
    if kind == "const":
        return Const(TRUE if formula[1] else FALSE)
    if kind == "not":
        return Not(build(formula[1], props))
    if kind in ("and", "or"):
        return Binary(kind, build(formula[1], props), build(formula[2], props))
    if kind in ("until", "since"):
        left, right = build(formula[3], props), build(formula[4], props)
        return Temporal(kind, formula[1], _plain(formula[2]), left, right)
    if kind == "cmp":
        return Compare(formula[1], _build_term(formula[2], props), _build_term(formula[3], props))
    raise ValueError(f"unknown formula node {kind!r}")


def _build_term(term: Any, props: dict[str, Prop]) -> Any:
    kind = term[0]
    if kind == "num":
        return ("num", _plain(term[1]))
    if kind == "dur":
        return ("dur", _plain(term[1]), build(term[2], props))
    if kind == "mul" and term[1][0] != "num" and term[2][0] != "num":
        raise ValueError("a product of two durations is not linear: one side must be a constant")
    return (kind, _build_term(term[1], props), _build_term(term[2], props))


def _order(root: Node) -> list[Node]:
    """Children before parents, each node once."""
    order: list[Node] = []
    seen: set[int] = set()
    stack: list[tuple[Node, bool]] = [(root, False)]
    while stack:
        node, expanded = stack.pop()
        if expanded:
            order.append(node)
            continue
        if id(node) in seen:
            continue
        seen.add(id(node))
        stack.append((node, True))
        stack.extend((child, False) for child in reversed(node.children()))
    return order


Segment = tuple[Any, Any, bool, bool, str]  # start, end, start closed, end closed, value


class Monitor:
    """Feed samples in time order; read verdict segments as they are decided.

        monitor = Monitor(("until", "<", 10, ("prop", "A"), ("prop", "B")))
        monitor.step(0, {"A"}); monitor.step(3, {"B"}); monitor.end(12)
        list(monitor.verdicts())   # [(0, 12, True, False, 'true')]

    A sample (t, state) says which propositions hold from t on. The input is known
    up to the newest sample (or the end given to `end`). `lateness`: samples may
    arrive this much out of order and are re-ordered; a later one is counted in
    `late`, and the input it would have changed becomes unknown.
    """

    def __init__(self, formula: Any, lateness: Any = 0) -> None:
        self.props: dict[str, Prop] = {}
        self.root = build(formula, self.props)
        self.order = _order(self.root)
        self.horizon = self.root.future + self.root.past
        self.lateness = lateness
        self.start: Any = None
        self.known: Any = None  # the input is known on [start, known)
        self.written: Any = None  # the atoms' signals are written up to here
        self.written_state: frozenset[str] = frozenset()  # the state at `written`
        self.written_pulses: frozenset[str] = _NO_PULSES  # and what holds at that point only
        self.changes: list[tuple[Any, frozenset[str], frozenset[str]]] = []  # since `written`
        self.state: frozenset[str] = frozenset()
        self.emitted: Any = None  # verdicts are out up to here
        self.emitted_point = False  # and for the point `emitted` itself
        self.pending: list[tuple[Any, int, frozenset[str], frozenset[str]]] = []
        self.count = 0
        self.newest: Any = None
        self.late: list[Any] = []
        self._out: list[Segment] = []

    # ---- input ----

    def step(self, t: Any, state: Iterable[str], pulses: Iterable[str] = _NO_PULSES) -> None:
        """The propositions that hold from time t on, and `pulses`: those that hold
        at the instant t only (an event a transducer emits, which lasts no time)."""
        state = state if isinstance(state, frozenset) else frozenset(state)
        pulses = pulses if isinstance(pulses, frozenset) else frozenset(pulses)
        if self.lateness:
            self._hold(t, state, pulses)
        else:
            self._advance(t, state, pulses)

    def feed(self, samples: Iterable[tuple[Any, Iterable[str]]]) -> None:
        """Many samples. One that repeats the current state only moves the known end
        of the input: the fast path of a periodic sampler."""
        if self.lateness:
            for t, state in samples:
                self.step(t, state)
            return
        iterator = iter(samples)
        if self.start is None:
            for t, state in iterator:
                self._advance(t, frozenset(state))
                break
        current, known, changes = self.state, self.known, self.changes
        # _advance's usual case inlined: a change in time order
        for t, state in iterator:
            # The same object (a sampler reusing its state) is the cheapest test.
            if (state is current or state == current) and t >= known:
                known = t
                continue
            if type(state) is not frozenset:
                state = frozenset(state)
            if t < known:  # late: counted and made unknown
                self.known = known
                self._advance(t, state)
                current, known = self.state, self.known
                continue
            known, current = t, state
            changes.append((t, state, _NO_PULSES))
            if self._batch_due(t):
                self.known, self.state = known, current
                self._flush()
        self.known, self.state = known, current

    def advance(self, t: Any) -> None:
        """The input is known, unchanged, up to t (a live host's clock passed it
        with no new sample): decide everything that decides, now."""
        if self.start is None or self.lateness or t <= self.known:
            return
        self.known = t
        self._flush()

    def end(self, t: Any) -> None:
        """The input ends at t: the last state held until t; nothing is known after."""
        while self.pending:
            when, _, held, pulses = heapq.heappop(self.pending)
            self._advance(when, held, pulses)
        if self.start is None:
            return
        if t > self.known:
            self.known = t
        self._recompute()
        self._emit(final=True)

    def beyond(self) -> list[Segment]:
        """After `end`: the verdicts from the end of the input on, as far as the input
        decides them (`true` stays true; `once[=20] p` is known for 20 more). The
        unknown that runs for ever is left out."""
        self._flush()
        if self.start is None:
            return []
        tail = self._segments(self.known, _INFINITY)
        if tail and tail[-1][4] == "unknown":
            tail.pop()
        return tail

    def _hold(self, t: Any, state: frozenset[str], pulses: frozenset[str]) -> None:
        self.count += 1
        heapq.heappush(self.pending, (t, self.count, state, pulses))
        self.newest = t if self.newest is None or t > self.newest else self.newest
        while self.pending and self.pending[0][0] <= self.newest - self.lateness:
            when, _, held, pulsed = heapq.heappop(self.pending)
            self._advance(when, held, pulsed)

    def _advance(self, t: Any, state: frozenset[str], pulses: frozenset[str] = _NO_PULSES) -> None:
        if self.start is None:
            self._begin(t, state)
            self.written_pulses = pulses
        elif t < self.known:
            self._late_sample(t)
        elif state == self.state and not pulses:
            self.known = t
        else:
            self.known = t
            self.changes.append((t, state, pulses))
            self.state = state
            if self._batch_due(t):
                self._flush()

    def _batch_due(self, t: Any) -> bool:
        """Whether the changes held should be computed now: once they span the
        horizon and make a batch (or span many horizons). What is held stays within
        twice the horizon plus one batch; a batch pays a recomputation's fixed cost
        once."""
        waited = t - self.written
        return waited > self.horizon and (
            len(self.changes) >= BATCH or waited > SPARSE_HORIZONS * self.horizon
        )

    def _flush(self) -> None:
        """Compute everything the input so far decides."""
        if self.start is not None and (self.changes or self.known > self.written):
            self._recompute()
            self._emit(final=False)

    def _begin(self, t: Any, state: frozenset[str]) -> None:
        self.start = self.known = self.written = self.emitted = t
        self.state = self.written_state = state
        for node in self.order:
            node.reset(t)
            if isinstance(node, Temporal):
                node.origin = t

    def _recompute(self) -> None:
        """Write the input on [written, known), then update every node from where
        that input can change it."""
        begin = self.written
        for name, prop in self.props.items():
            value = TRUE if name in self.written_state else FALSE
            point = TRUE if name in self.written_pulses else value
            signal = prop.signal
            signal.cut(begin)
            signal.append(begin, point, value)
            for when, state, pulses in self.changes:
                value = TRUE if name in state else FALSE
                signal.append(when, TRUE if name in pulses else value, value)
            signal.append(self.known, UNKNOWN, UNKNOWN)
        last = self.changes[-1] if self.changes else None
        self.written_pulses = (
            last[2]
            if last and last[0] == self.known
            else (self.written_pulses if begin == self.known else _NO_PULSES)
        )
        self.written, self.written_state = self.known, self.state
        self.changes.clear()
        self._update_nodes(begin)
        # History for the verdicts still to come (a horizon back) and for revising
        # them after a sample late by up to one more horizon (`_late_sample`).
        keep = self.known - 2 * self.horizon - 1
        for node in self.order:
            node.signal.drop_before(min(keep, self.emitted) if node is self.root else keep)

    def _update_nodes(self, changed: Any) -> None:
        for node in self.order:
            if isinstance(node, Evaluated | Not | Binary):
                begin = changed - node.future
                node.update(begin if begin > self.start else self.start)

    def _late_sample(self, t: Any) -> None:
        self._flush()
        self.late.append(t)
        # Re-evaluating from t reads every node's signal from a horizon before t.
        oldest = max((n.signal.starts[0] for n in self.order), default=self.start)
        if t < self.start or max(t - self.horizon, self.start) < oldest:
            return  # older than the history kept: counted, not re-evaluated
        for prop in self.props.values():
            signal = prop.signal
            following = next((s for s in signal.starts if s > t), self.known)
            following = min(following, self.known)
            tail = [
                (s, p, o)
                for s, p, o in zip(signal.starts, signal.points, signal.opens, strict=True)
                if s >= following
            ]
            signal.cut(t)
            signal.append(t, UNKNOWN, UNKNOWN)
            for s, p, o in tail:
                signal.append(s, p, o)
        self._update_nodes(t)
        since = t - self.root.future
        if since < self.emitted:
            self._revise(since if since > self.start else self.start)

    def _revise(self, since: Any) -> None:
        """What a late sample made uncertain is re-emitted as unknown."""
        for segment in self._segments(since, self.emitted):
            if segment[4] == "unknown":
                self._out.append((*segment[:4], "unknown (revised: late input)"))

    # ---- output ----

    def _segments(self, low: Any, high: Any, low_done: bool = False) -> list[Segment]:
        """The root signal from low to high (open) as maximal segments; the point
        low itself is left out when `low_done`."""
        signal = self.root.signal
        out: list[Segment] = []

        def add(a: Any, b: Any, a_closed: bool, b_closed: bool, value: int) -> None:
            segment = (a, b, a_closed, b_closed, NAMES[value])
            if out and continues(out[-1], segment):
                out[-1] = extended(out[-1], segment)
            elif a < b or (a_closed and b_closed):
                out.append(segment)

        i = signal.index(low)
        for k in range(i, len(signal.starts)):
            point = signal.starts[k]
            if point >= high:
                break
            if point >= low and not (point == low and low_done):
                add(point, point, True, True, signal.points[k])
            end = signal.starts[k + 1] if k + 1 < len(signal.starts) else high
            end = end if end < high else high
            if point < low:
                add(low, end, not low_done, False, signal.opens[k])
            else:
                add(point, end, False, False, signal.opens[k])
        return out

    def _emit(self, final: bool) -> None:
        for segment in self._segments(self.emitted, self.known, self.emitted_point):
            if segment[4] == "unknown" and not final:
                return
            self._out.append(segment)
            self.emitted, self.emitted_point = segment[1], segment[3]

    def verdicts(self) -> Iterator[Segment]:
        """Verdict segments decided since the last call, in time order."""
        self._flush()
        out, self._out = self._out, []
        return iter(out)

    def verdict_at(self, t: Any) -> str:
        """The verdict at time t, as far as the input so far decides it."""
        self._flush()
        if self.start is None or t < self.root.signal.starts[0]:
            return "unknown"
        return NAMES[self.root.signal.at(t)]

    def memory(self) -> int:
        """Breakpoints held over all nodes: bounded by the horizon, not the trace."""
        return sum(len(node.signal.starts) for node in self.order) + len(self.pending)


class Facts(NamedTuple):
    """What one walk over a compiled formula finds (docs/semantics.md, "horizon")."""

    future: Any  # how far it looks ahead
    past: Any  # how far it looks back
    propositions: tuple[str, ...]  # left to right, each once
    has_past: bool  # a `since` (or `once`, `historically`) inside


def facts(formula: Any) -> Facts:
    """Horizon, propositions and past-ness in one traversal, by a loop (formulas can
    be 100,000 levels deep). The monitor's nodes compute the same horizon each for
    itself; a test keeps the two equal."""
    done: dict[int, tuple[Any, Any, bool]] = {}
    names: dict[str, None] = {}
    stack: list[tuple[Any, bool]] = [(formula, False)]
    while stack:
        node, expanded = stack.pop()
        children = [c for c in node[1:] if isinstance(c, tuple)]
        if not expanded:
            if node[0] == "prop":
                names.setdefault(node[1], None)
            stack.append((node, True))
            stack.extend((child, False) for child in reversed(children))
            continue
        parts = [done[id(child)] for child in children]
        future = max((p[0] for p in parts), default=0)
        past = max((p[1] for p in parts), default=0)
        backwards = node[0] == "since" or any(p[2] for p in parts)
        if node[0] == "until":
            future += node[2]
        elif node[0] == "since":
            past += node[2]
        elif node[0] == "dur":
            future += node[1]
        done[id(node)] = (future, past, backwards)
    future, past, backwards = done[id(formula)]
    return Facts(future, past, tuple(names), backwards)


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
