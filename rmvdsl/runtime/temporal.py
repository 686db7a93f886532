"""The nodes of a compiled RMTLD3 formula: constants, propositions, `not`,
`and`/`or`, the bounded temporal operators `until`/`since` and `since` with no
bound, each recomputing its signal only from where new input can change it."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

from rmvdsl.runtime.covers import Levels, Witnesses, cover, since_levels, until_levels, write
from rmvdsl.runtime.signal import _INFINITY, AND, FALSE, OR, TRUE, UNKNOWN, Signal, _mid, pieces


class Node:
    future: Any = 0  # how far the subformula looks ahead of the time it is evaluated at
    past: Any = 0  # and back (infinite under a `since` with no bound)
    reach: Any = 0  # how far back its update reads its children's signals (finite)

    def __init__(self) -> None:
        self.signal = Signal(0, UNKNOWN)

    def reset(self, start: Any) -> None:
        self.signal = Signal(start, UNKNOWN)

    def update(self, start: Any) -> None:
        """Recompute the signal on [start, infinity) from the children's."""

    def children(self) -> list[Node]:
        return []

    def forget_before(self, t: Any) -> None:
        """Drop what no update reads any more: the signal before t."""
        self.signal.drop_before(t)


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
        self.future, self.past, self.reach = child.future, child.past, child.reach

    def children(self) -> list[Node]:
        return [self.child]

    def update(self, start: Any) -> None:
        source, signal = self.child.signal, self.signal
        signal.cut(start)
        i = source.index(start)
        signal.append(start, 2 - source.at(start), 2 - source.opens[i])
        # Signal.append inlined (each time here is past the last written): these
        # loops write most breakpoints a monitor makes
        starts, points, opens, last = signal.starts, signal.points, signal.opens, signal.opens[-1]
        for t, point, after in zip(
            source.starts[i + 1 :], source.points[i + 1 :], source.opens[i + 1 :], strict=True
        ):
            point, after = 2 - point, 2 - after
            if not last == point == after:
                starts.append(t)
                points.append(point)
                opens.append(after)
                last = after


class Binary(Node):
    def __init__(self, op: str, left: Node, right: Node) -> None:
        super().__init__()
        self.table = AND if op == "and" else OR
        self.left, self.right = left, right
        self.future = max(left.future, right.future)
        self.past = max(left.past, right.past)
        self.reach = max(left.reach, right.reach)

    def children(self) -> list[Node]:
        return [self.left, self.right]

    def update(self, start: Any) -> None:
        """One merge walk over both children's breakpoints from `start` on."""
        a, b, signal, table = self.left.signal, self.right.signal, self.signal, self.table
        signal.cut(start)
        a_starts, a_points, a_opens = a.starts, a.points, a.opens
        b_starts, b_points, b_opens = b.starts, b.points, b.opens
        i, j = a.index(start), b.index(start)
        a_point = a_points[i] if a_starts[i] == start else a_opens[i]
        b_point = b_points[j] if b_starts[j] == start else b_opens[j]
        signal.append(start, table[a_point][b_point], table[a_opens[i]][b_opens[j]])
        i, j = i + 1, j + 1
        a_count, b_count = len(a_starts), len(b_starts)
        starts, points, opens, last = signal.starts, signal.points, signal.opens, signal.opens[-1]
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
            point, after = table[a_point][b_point], table[a_open][b_open]
            if not last == point == after:  # Signal.append inlined, as in Not
                starts.append(t)
                points.append(point)
                opens.append(after)
                last = after


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
        ends = [*points, (points[-1] if points else start) + self.future + self.reach + 1]
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
        self.reach = max(left.reach, right.reach)
        if kind == "until":
            self.future, self.past = future + bound, past
        else:
            self.future, self.past = future, past + bound
            self.reach += bound
        # `eventually` and `once` (true on the left): the value is the sup of psi
        # over the window, read from the segment lists in one slice.
        self.plain = isinstance(left, Const) and left.value == TRUE
        self.witnesses = Witnesses()  # a `since` with a window: what it carries over

    def reset(self, start: Any) -> None:
        super().reset(start)
        self.witnesses = Witnesses()

    def forget_before(self, t: Any) -> None:
        super().forget_before(t)
        self.witnesses.forget_before(t)

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
        windowed = self.op != "=" and (self.op == "<=" or self.bound > 0)
        if self.plain and self.op == "=":
            self._shift(start)
        elif self.plain and windowed:
            self._dilate(start)
        elif self.kind == "since" and windowed:
            left, right, closed = self.left.signal, self.right.signal, self.op == "<="
            levels = since_levels(left, right, start, self.bound, closed, self.witnesses)
            write(self.signal, start, levels)
        elif windowed:  # until
            left, right, closed = self.left.signal, self.right.signal, self.op == "<="
            write(self.signal, start, until_levels(left, right, start, self.bound, closed))
        else:
            super().update(start)

    def _shift(self, start: Any) -> None:
        """`eventually[=T] psi` and `once[=T] psi`: psi shifted by T (`once` false
        before T has passed since the origin)."""
        psi, out = self.right.signal, self.signal
        shift = self.bound if self.kind == "since" else -self.bound
        out.cut(start)
        begin = start
        if self.kind == "since" and start < self.origin + self.bound:
            out.append(start, FALSE, FALSE)
            begin = self.origin + self.bound
        i = psi.index(begin - shift)
        out.append(begin, psi.at(begin - shift), psi.opens[i])
        starts, points, opens, last = out.starts, out.points, out.opens, out.opens[-1]
        for t, point, after in zip(
            psi.starts[i + 1 :], psi.points[i + 1 :], psi.opens[i + 1 :], strict=True
        ):
            if not last == point == after:  # Signal.append inlined, as in Not
                starts.append(t + shift)
                points.append(point)
                opens.append(after)
                last = after

    def _dilate(self, start: Any) -> None:
        """`eventually` and `once` in one pass: each piece of psi (a point or an open
        interval) makes the result at least its value over the interval of t whose
        window meets it; the result is the highest level covering t. The pieces'
        intervals have ordered ends, so each level's union is one merge."""
        psi, bound, closed = self.right.signal, self.bound, self.op == "<="
        past = self.kind == "since"
        starts, points, opens = psi.starts, psi.points, psi.opens
        count = len(starts)
        levels: Levels = ([], [])
        for k in range(psi.index(start - bound if past else start), count):
            at = starts[k]
            following = starts[k + 1] if k + 1 < count else _INFINITY
            if points[k]:
                if past:
                    cover(levels, points[k], at, True, at + bound, closed)
                else:
                    cover(levels, points[k], at - bound, closed, at, True)
            if opens[k]:
                if past:
                    cover(levels, opens[k], at, False, following + bound, False)
                else:
                    cover(levels, opens[k], at - bound, False, following, False)
        write(self.signal, start, levels)

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
            if prefix == FALSE:  # phi failed: no later t' can raise the supremum
                return best
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
        low, low_closed = (begin, op == "<=") if begin >= self.origin else (self.origin, True)
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
            if suffix == FALSE:  # phi failed: no earlier t' can raise the supremum
                return best
            cursor = point
        if low_closed and low < t:
            best = max(best, min(psi.at(low), suffix))
        return best


class Ever(Node):
    """`since` with no bound, and so `once` and `historically` with none: phi has held
    since a time psi held, at any time back to the start. Constant memory: the value
    at t follows from the value pending at an earlier time s and the children on
    [s, t], so an update reads its children from where it starts and, before that,
    only `pending`: at each time t, the best psi at t' < t with phi on (t', t)."""

    origin: Any = 0

    def __init__(self, left: Node, right: Node) -> None:
        super().__init__()
        self.left, self.right = left, right
        self.future = max(left.future, right.future)
        self.past = _INFINITY
        self.reach = max(left.reach, right.reach)
        self.pending = Signal(0, FALSE)

    def children(self) -> list[Node]:
        return [self.left, self.right]

    def reset(self, start: Any) -> None:
        super().reset(start)
        self.pending = Signal(start, FALSE)

    def forget_before(self, t: Any) -> None:
        super().forget_before(t)
        self.pending.drop_before(t)

    def update(self, start: Any) -> None:
        """One walk over the children's breakpoints from `start` on. At a point p
        the value is psi(p), or what was pending with phi(p); on the open interval
        after it, psi there, or the value at p with phi there; and what is pending
        over that interval is the value at p or psi there, with phi there."""
        phi, psi, out, pending = self.left.signal, self.right.signal, self.signal, self.pending
        carried = pending.at(start) if start > self.origin else FALSE
        out.cut(start)
        pending.cut(start)
        o_starts, o_points, o_opens = out.starts, out.points, out.opens
        p_starts, p_points, p_opens = pending.starts, pending.points, pending.opens
        for t, phi_at, phi_after, psi_at, psi_after in pieces(phi, psi, start):
            value = OR[AND[carried][phi_at]][psi_at]
            carried_after = AND[OR[value][psi_after]][phi_after]
            after = OR[AND[value][phi_after]][psi_after]
            if t == o_starts[-1] or t == p_starts[-1]:  # the first piece, where cut
                out.append(t, value, after)
                pending.append(t, carried, carried_after)
            else:  # Signal.append inlined, as in Not
                if not o_opens[-1] == value == after:
                    o_starts.append(t)
                    o_points.append(value)
                    o_opens.append(after)
                if not p_opens[-1] == carried == carried_after:
                    p_starts.append(t)
                    p_points.append(carried)
                    p_opens.append(carried_after)
            carried = carried_after
