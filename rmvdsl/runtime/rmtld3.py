"""An online monitor for RMTLD3, exact in dense time (docs/semantics.md).

This module uses the Python standard library only: generated ROS nodes embed it.
Formulas come as nested tuples (`rmvdsl.logic.compile` makes them):

    ("prop", name)  ("const", bool)  ("not", f)  ("and", f, g)  ("or", f, g)
    ("until", op, T, f, g)  ("since", op, T, f, g)        op: "<", "<=", "="
    ("since", "<=", None, f, g): since with no bound, over the whole trace so far
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

import heapq
from collections.abc import Iterable, Iterator
from typing import Any

from rmvdsl.runtime.durations import Compare, arithmetic, compare, duration
from rmvdsl.runtime.facts import Facts, facts
from rmvdsl.runtime.nesting import flattened
from rmvdsl.runtime.segments import Segment, continues, extended, merge, merged
from rmvdsl.runtime.signal import (
    _INFINITY,
    FALSE,
    NAMES,
    TRUE,
    UNKNOWN,
    Signal,
    plain,
)
from rmvdsl.runtime.temporal import Binary, Const, Evaluated, Ever, Node, Not, Prop, Temporal

# The formula's parts, defined beside this module, read through it.
__all__ = [
    "BATCH", "FALSE", "NAMES", "TRUE", "UNKNOWN", "Binary", "Compare", "Const",
    "Evaluated", "Ever", "Facts", "Monitor", "Node", "Not", "Prop", "Segment", "Signal",
    "Temporal", "arithmetic", "build", "compare", "continues", "duration", "extended",
    "facts", "merge", "merged",
]  # fmt: skip

_NO_PULSES: frozenset[str] = frozenset()
BATCH = 256  # changes recomputed together once the input spans the horizon
# A change of the input: its time, the propositions then holding, those pulsed.
Change = tuple[Any, frozenset[str], frozenset[str]]
SPARSE_HORIZONS = 32  # or once it spans this many horizons


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
        if formula[2] is None:
            if kind == "until":
                raise ValueError("`until` needs a bound")
            return Ever(left, right)
        return Temporal(kind, formula[1], plain(formula[2]), left, right)
    if kind == "cmp":
        return Compare(formula[1], _build_term(formula[2], props), _build_term(formula[3], props))
    raise ValueError(f"unknown formula node {kind!r}")


def _build_term(term: Any, props: dict[str, Prop]) -> Any:
    kind = term[0]
    if kind == "num":
        return ("num", plain(term[1]))
    if kind == "dur":
        return ("dur", plain(term[1]), build(term[2], props))
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
        # Nested windows of one kind run as one (rmvdsl.runtime.nesting): the
        # same verdicts, one node where ten nested `eventually` made ten.
        self.root = build(flattened(formula), self.props)
        self.order = _order(self.root)
        # What the nodes read, ahead and back: history older than this is dropped
        # (a `since` with no bound keeps what it needs in constant memory).
        self.horizon = self.root.future + self.root.reach
        self.lateness = lateness
        self.start: Any = None
        self.known: Any = None  # the input is known on [start, known)
        self.written: Any = None  # the atoms' signals are written up to here
        self.written_state: frozenset[str] = frozenset()  # the state at `written`
        self.written_pulses: frozenset[str] = _NO_PULSES  # and what holds at that point only
        self.changes: list[Change] = []  # since `written`
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
            if isinstance(node, Temporal | Ever):
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
            _write_changes(signal, name, self.changes)
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
            node.forget_before(min(keep, self.emitted) if node is self.root else keep)

    def _update_nodes(self, changed: Any) -> None:
        for node in self.order:
            if isinstance(node, Evaluated | Not | Binary | Ever):
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
        """The verdict at time t, as far as the input so far decides it: a live
        query. The signals keep only the history a live monitor needs (about two
        horizons before the newest input), so an older t reads "unknown"; a whole
        run's verdicts are `verdicts()` (rmvdsl.runtime.segments.verdict_at)."""
        self._flush()
        if self.start is None or t < self.root.signal.starts[0]:
            return "unknown"
        return NAMES[self.root.signal.at(t)]

    def signals(self) -> list[Signal]:
        """Every signal the nodes keep: one each, two for a `since` with no bound."""
        kept = [node.signal for node in self.order]
        return kept + [node.pending for node in self.order if isinstance(node, Ever)]

    def lists(self) -> int:
        """How many lists of breakpoints the nodes keep: a signal each, and for a
        `since` its witnesses (with a window) or what is pending (with none)."""
        since = [n for n in self.order if isinstance(n, Temporal) and n.kind == "since"]
        pending = [n for n in self.order if isinstance(n, Ever)]
        return len(self.order) + len(since) + len(pending)

    def memory(self) -> int:
        """Breakpoints held over all nodes: bounded by the horizon, not the trace."""
        carried = sum(len(n.witnesses.times) for n in self.order if isinstance(n, Temporal))
        return sum(len(signal.starts) for signal in self.signals()) + carried + len(self.pending)


def _write_changes(signal: Signal, name: str, changes: list[Change]) -> None:
    """A proposition's value at each change, appended as `Signal.append` would
    (inlined: a batch's changes are most of what the monitor does per sample)."""
    starts, points, opens = signal.starts, signal.points, signal.opens
    last = opens[-1]
    for when, state, pulses in changes:
        value = TRUE if name in state else FALSE
        point = TRUE if name in pulses else value
        if when == starts[-1]:  # a change at the batch's first instant
            signal.append(when, point, value)
            last = opens[-1]
        elif not last == point == value:
            starts.append(when)
            points.append(point)
            opens.append(value)
            last = value
