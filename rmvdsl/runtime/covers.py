"""The windowed past and future operators in one sweep each: the value at t is the
highest level (1: not false, 2: true) for which t lies in a union of intervals, one
interval per piece of psi (a point, or an open interval between two breakpoints),
each the times whose window meets the piece (rmvdsl/runtime/temporal.py; the
operators' meaning is docs/semantics.md). Standard library only."""

from __future__ import annotations

import bisect
from typing import Any

from rmvdsl.runtime.signal import _INFINITY, Signal, pieces

Interval = list[Any]  # [low, low closed, high, high closed]
Levels = tuple[list[Interval], list[Interval]]  # value >= 1, value == 2
End = tuple[Any, bool]  # a time and whether it is included


def cover(levels: Levels, value: int, low: Any, low_closed: bool, high: Any,
          high_closed: bool) -> None:  # fmt: skip
    """Add an interval where the result is at least `value` (1 or 2) to the union of
    each level it reaches."""
    for intervals in levels[:value]:
        add(intervals, low, low_closed, high, high_closed)


def add(intervals: list[Interval], low: Any, low_closed: bool, high: Any,
        high_closed: bool) -> None:  # fmt: skip
    """Add an interval to a union kept as disjoint intervals in order. Intervals come
    with ordered lows and highs."""
    if intervals:
        last = intervals[-1]
        if low < last[2] or (low == last[2] and (low_closed or last[3])):
            if high > last[2]:
                last[2], last[3] = high, high_closed
            elif high == last[2]:
                last[3] = last[3] or high_closed
            return
    intervals.append([low, low_closed, high, high_closed])


def write(signal: Signal, start: Any, levels: Levels) -> None:
    """The signal from `start` on: at each time, how many levels cover it. Each
    level's union is a step function read off its intervals in one pass (they are
    disjoint and in order, and two of them meet only at a point neither holds:
    `add`); the two are summed in one merge walk."""
    signal.cut(start)
    ones, twos = (_steps(level, start) for level in levels)
    signal.append(start, ones[0][1] + twos[0][1], ones[0][2] + twos[0][2])
    # Signal.append inlined (each later time is past the last written)
    starts, points, opens, last = signal.starts, signal.points, signal.opens, signal.opens[-1]
    i = j = 1
    one_count, two_count = len(ones), len(twos)
    one_after, two_after = ones[0][2], twos[0][2]
    while i < one_count or j < two_count:
        one_next = ones[i][0] if i < one_count else _INFINITY
        two_next = twos[j][0] if j < two_count else _INFINITY
        t = one_next if one_next < two_next else two_next
        if one_next == t:
            _, one_point, one_after = ones[i]
            i += 1
        else:
            one_point = one_after
        if two_next == t:
            _, two_point, two_after = twos[j]
            j += 1
        else:
            two_point = two_after
        point, after = one_point + two_point, one_after + two_after
        if not last == point == after:
            starts.append(t)
            points.append(point)
            opens.append(after)
            last = after


def _steps(intervals: list[Interval], start: Any) -> list[tuple[Any, int, int]]:
    """A union's indicator from `start` on: (time, 1 if covered there, 1 if just
    after), at `start` and at each end of an interval after it."""
    steps: list[tuple[Any, int, int]] = [(start, 0, 0)]
    for low, low_closed, high, high_closed in intervals:
        if high < start or (high == start and not high_closed):
            continue  # over before start
        if low < start or (low == start and steps[-1][0] == start):
            point = 1 if low < start or low_closed else 0
            steps[-1] = (start, point, 1 if high > start else 0)
        elif steps[-1][0] == low:  # where the interval before ends, open both sides
            steps[-1] = (low, steps[-1][1] or int(low_closed), 1 if high > low else 0)
        else:
            steps.append((low, int(low_closed), 1 if high > low else 0))
        if start < high < _INFINITY and high > low:
            steps.append((high, int(high_closed), 0))
    return steps


# ---- `phi since[<T] psi` and `phi since[<=T] psi` ----

Witness = tuple[Any, bool] | None  # the latest t' (and whether it is attained), or none


class Witnesses:
    """What a `since` with a window carries over from before an update's start, at
    each level: the latest t' before x where psi >= k with phi >= k on (t', x),
    kept at every breakpoint of its operands (the standard past-time algorithm:
    keep the last witness). An update then reads its operands from its start on
    only, whatever the window's length."""

    def __init__(self) -> None:
        self.times: list[Any] = []
        self.found: list[tuple[Witness, Witness]] = []

    def cut(self, t: Any) -> None:
        index = bisect.bisect_left(self.times, t)
        del self.times[index:], self.found[index:]

    def forget_before(self, t: Any) -> None:
        index = bisect.bisect_right(self.times, t) - 1
        if index > 0:
            del self.times[:index], self.found[:index]

    def at(self, x: Any, phi: Signal, psi: Signal) -> tuple[Witness, Witness]:
        index = bisect.bisect_right(self.times, x) - 1
        if index < 0:
            return None, None
        p = self.times[index]
        if p == x:
            return self.found[index]
        return _carried(self.found[index], p, phi, psi)


def _carried(found: tuple[Witness, Witness], p: Any, phi: Signal,
             psi: Signal) -> tuple[Witness, Witness]:  # fmt: skip
    """The witnesses just after p (on the open interval to the next breakpoint)."""
    return _step(found, phi.at(p), phi.right_of(p), psi.at(p), psi.right_of(p), p)


def _step(found: tuple[Witness, Witness], phi_at: int, phi_after: int, psi_at: int,
          psi_after: int, p: Any) -> tuple[Witness, Witness]:  # fmt: skip
    """From the witnesses at p to those just after it: psi there is its own witness
    (not attained: `_NOW`), else psi at p, else what p carried, each only while phi
    holds on. (One call per breakpoint: the two levels written out, since a loop
    over them made a `zip(..., strict=True)` each, whose keyword alone cost more
    than the rest.)"""
    first, second = found
    return (
        _witness(1, first, phi_at, phi_after, psi_at, psi_after, p),
        _witness(2, second, phi_at, phi_after, psi_at, psi_after, p),
    )


def _witness(level: int, witness: Witness, phi_at: int, phi_after: int, psi_at: int,
             psi_after: int, p: Any) -> Witness:  # fmt: skip
    if phi_after < level:
        return None
    if psi_after >= level:
        return _NOW, False
    if psi_at >= level:
        return p, True
    return witness if phi_at >= level else None


_NOW = object()  # a witness at x itself, not attained: psi holds just before x


def since_levels(phi: Signal, psi: Signal, start: Any, bound: Any, closed: bool,
                 memo: Witnesses) -> Levels:  # fmt: skip
    """At level k, t is covered where psi >= k at some t' in the window with
    phi >= k on (t', t]. What came before `start` covers, at each level, from start
    to a bound past the latest witness, while phi holds (`memo`); a piece of psi
    from start on covers itself (t' = t) and the times after it, up to a bound past
    its end, while phi holds from its last instant. The end of phi's run is read
    from a table built once per update: the sweep is linear in the breakpoints
    since `start`, whatever the bound."""
    levels: Levels = ([], [])
    first = psi.index(start)
    base = phi.index(start)
    # A witness just before `start` (psi held up to it) is `start`, not attained:
    # resolved here, or the walk below would carry `_NOW` on to the next breakpoint
    # and take that for the witness.
    carried = _at(memo.at(start, phi, psi), start) if start > psi.starts[0] else (None, None)
    _remember(memo, phi, psi, start, carried)
    starts, points, opens = psi.starts, psi.points, psi.opens
    count = len(starts)
    for level, intervals in zip((1, 2), levels, strict=True):
        after_point, after_open = _runs(phi, base, level)
        witness = carried[level - 1]
        if witness is not None:  # t' before start, phi on (t', start): and from start on
            run = _run_at(phi, base, start, level, after_point, after_open)
            if run:
                high = _earlier((witness[0] + bound, closed and witness[1]), run)
                if high[0] > start or (high[0] == start and high[1]):
                    add(intervals, start, True, *high)
        for k in range(first, count):
            at = starts[k]
            following = starts[k + 1] if k + 1 < count else _INFINITY
            if points[k] >= level and at >= start:  # t' = at: phi on (at, t]
                run = after_open[phi.index(at) - base]
                high = _earlier((at + bound, closed), run) if run else (at, True)
                add(intervals, at, True, *high)
            if opens[k] >= level:  # t' just before `following`: phi on (following - e, t]
                run = None
                if following != _INFINITY:
                    run = _run_from(phi, base, following, level, after_point, after_open)
                high = _earlier((following + bound, False), run) if run else (following, False)
                add(intervals, max(at, start), at < start, *high)
    return levels


def _remember(memo: Witnesses, phi: Signal, psi: Signal, start: Any,
              carried: tuple[Witness, Witness]) -> None:  # fmt: skip
    """The witnesses at every breakpoint of phi and psi from `start` on, in one walk
    over both."""
    memo.cut(start)
    after: tuple[Witness, Witness] = carried
    for t, phi_at, phi_after, psi_at, psi_after in pieces(phi, psi, start):
        # what held just after the previous breakpoint, with psi there a witness at t
        found = carried if t == start else _at(after, t)
        memo.times.append(t)
        memo.found.append(found)
        after = _step(found, phi_at, phi_after, psi_at, psi_after, t)


def _at(after: tuple[Witness, Witness], t: Any) -> tuple[Witness, Witness]:
    """The witnesses at t from those on the open interval before it: psi held there
    up to t, so t is the latest witness, not attained."""
    first, second = after
    if first is not None and first[0] is _NOW:
        first = (t, False)
    if second is not None and second[0] is _NOW:
        second = (t, False)
    return first, second


def _runs(phi: Signal, base: int, level: int) -> tuple[list[End | None], list[End | None]]:
    """For each breakpoint of phi from `base` on: how far phi >= level holds from the
    point on (`after_point`) and from the open interval after it on (`after_open`),
    as the last time t for which it holds on all of (x, t]; None: not even there."""
    starts, points, opens = phi.starts, phi.points, phi.opens
    count = len(starts) - base
    after_point: list[End | None] = [None] * count
    after_open: list[End | None] = [None] * count
    following: End | None = (_INFINITY, False)  # what holds from the next point on
    for m in range(count - 1, -1, -1):
        index = base + m
        if opens[index] >= level:
            after_open[m] = following if following else (starts[index + 1], False)
        if points[index] >= level:
            after_point[m] = after_open[m] or (starts[index], True)
        following = after_point[m]
    return after_point, after_open


def _run_from(phi: Signal, base: int, at: Any, level: int, after_point: list[End | None],
              after_open: list[End | None]) -> End | None:  # fmt: skip
    """How far phi >= level holds from just before `at` on (None: not at `at`)."""
    index = phi.index(at)
    if phi.starts[index] == at:  # the open interval before it, then the point
        before = phi.opens[index - 1] if index > 0 else phi.opens[index]
        return after_point[index - base] if before >= level else None
    return after_open[index - base]


def _run_at(phi: Signal, base: int, at: Any, level: int, after_point: list[End | None],
            after_open: list[End | None]) -> End | None:  # fmt: skip
    """How far phi >= level holds from `at`, the point included, on."""
    index = phi.index(at)
    if phi.starts[index] == at:
        return after_point[index - base]
    return after_open[index - base]


def _earlier(a: End, b: End) -> End:
    if a[0] != b[0]:
        return a if a[0] < b[0] else b
    return a[0], a[1] and b[1]


# ---- `phi until[<T] psi` and `phi until[<=T] psi` ----


def until_levels(phi: Signal, psi: Signal, start: Any, bound: Any, closed: bool) -> Levels:
    """At level k, t is covered where psi >= k at some t' in [t, t + T) (or ]) with
    phi >= k on [t, t'). A point of psi at p covers from a bound before it, or from
    where phi's run up to p begins, to p; an open piece (s, e) covers itself and,
    where phi holds at s and up to it, the times before s whose window reaches past
    s. Nothing before `start` is read but the runs of phi into it (a future
    operator carries nothing over): linear in the breakpoints from `start` on."""
    levels: Levels = ([], [])
    base = phi.index(start)
    starts, points, opens = psi.starts, psi.points, psi.opens
    count = len(starts)
    first = psi.index(start)
    for level, intervals in zip((1, 2), levels, strict=True):
        before_open = _runs_back(phi, base, level)
        for k in range(first, count):
            at = starts[k]
            following = starts[k + 1] if k + 1 < count else _INFINITY
            if points[k] >= level and at >= start:  # t' = at: phi on [t, at)
                run = _run_before(phi, base, at, before_open)
                low = _later((at - bound, closed), run) if run else (at, True)
                add(intervals, *low, at, True)
            if opens[k] >= level and following > start:  # t' in (at, following)
                run = None
                if at >= start:  # phi on [t, at] and just after it (t' just past at)
                    run = before_open[phi.index(at) - base]
                low = _later((at - bound, False), run) if run else (at, False)
                add(intervals, *low, following, False)
    return levels


def _runs_back(phi: Signal, base: int, level: int) -> list[End | None]:
    """For each breakpoint of phi from `base` on: from where phi >= level holds up to
    the end of the open interval after it, as the first time b (and whether b itself
    holds) for which it holds on all of [b, x); None: not on that interval."""
    starts, points, opens = phi.starts, phi.points, phi.opens
    count = len(starts) - base
    before_open: list[End | None] = [None] * count
    previous: End | None = None  # the run through the open interval before the point
    for m in range(count):
        index = base + m
        if opens[index] >= level:
            if points[index] >= level:
                before_open[m] = previous or (starts[index], True)
            else:
                before_open[m] = (starts[index], False)
        previous = before_open[m]
    return before_open


def _run_before(phi: Signal, base: int, at: Any, before_open: list[End | None]) -> End | None:
    """From where phi >= level holds on [b, at), `at` itself not needed (None: not
    just before `at`; nor before the first breakpoint read, which the caller clips)."""
    index = phi.index(at)
    if phi.starts[index] == at:  # the open interval before it
        return before_open[index - 1 - base] if index - 1 >= base else None
    return before_open[index - base]


def _later(a: End, b: End) -> End:
    """The later of two lower ends (at one time, closed only if both are)."""
    if a[0] != b[0]:
        return a if a[0] > b[0] else b
    return a[0], a[1] and b[1]
