"""The spec's events and transducers as a dataflow (docs/runtime.md): each a node
that reads its inputs' items up to the time all of them are final, in dependency
order, so the output never depends on how the input was batched."""

from __future__ import annotations

import bisect
import graphlib
import heapq
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from typing import Any

from rmvdsl.runtime import influx
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.values import UNSET, same_value

_FOREVER = 1 << 126
Item = tuple[int, int, str, Any, str]  # time, sequence, name, value, source
START = ""  # the name of the item that makes a condition evaluate at the first instant


def _take(inbox: list[Item], bound: int) -> list[Item]:
    """Remove the items before `bound` from the heap `inbox`, oldest first (ties in
    arrival order). A heap, because items wait in an inbox until the slowest input
    of the node is final (a query running once a minute) while the others arrive."""
    if not inbox or inbox[0][0] >= bound:
        return []
    # A long inbox waiting on a slow input gives its head only, popped. Items come
    # mostly in time order, so the heap's last is mostly the newest: such an
    # inbox is told apart without a scan.
    if inbox[-1][0] >= bound and len(inbox) > SORTED_AT_MOST:
        taken = []
        while inbox and inbox[0][0] < bound:
            taken.append(heapq.heappop(inbox))
        return taken
    # Else sorted in one call, the order the pops would give (sequence numbers are
    # unique: no two items compare equal, and no value is compared); the items
    # left, sorted, are still a heap.
    ordered = sorted(inbox)
    if ordered[-1][0] < bound:
        inbox.clear()
        return ordered
    cut = bisect.bisect_left(ordered, (bound,))  # the first item at `bound` or later
    inbox[:] = ordered[cut:]
    return ordered[:cut]


# The longest inbox sorted whole when its newest item stays (a pump takes about
# PUMP_EVERY instants' items, and leaves those of the instant not yet final).
SORTED_AT_MOST = 64


class Node(ABC):
    """A step of the dataflow: reads items of `reads`, writes items of `writes`."""

    name: str
    reads: tuple[str, ...]
    writes: tuple[str, ...]
    reactive = True  # changes only when an input arrives (a query runs on a clock)
    lead = 0  # an input at t changes this node's output from t - lead on (ns)

    def __init__(self) -> None:
        self.inbox: list[Item] = []
        self.final = -_FOREVER  # output before this time is final

    def take(self, bound: int) -> list[Item]:
        return _take(self.inbox, bound) if self.inbox else []

    @abstractmethod
    def process(self, bound: int, emit: Callable[[int, str, Any, str], None]) -> None:
        """Consume the inbox before `bound`, emit what that decides, set `final`."""


def _instants(items: list[Item]) -> Iterable[tuple[int, list[Item]]]:
    """Items grouped by time."""
    start = 0
    for i in range(1, len(items) + 1):
        if i == len(items) or items[i][0] != items[start][0]:
            yield items[start][0], items[start:i]
            start = i


def _rows(items: list[Item]) -> Iterable[influx.Row]:
    """Items of one source at one time form one row (one message, one point)."""
    rows: dict[tuple[int, str], influx.Row] = {}
    row, row_source = None, ""
    for time, _, name, value, source in items:
        # a message's items come one after another: most items join the row before
        if row is None or time != row.time or source != row_source:
            row, row_source = rows.get((time, source)), source
            if row is None:
                row = rows[(time, source)] = influx.Row(time, {})
        row.fields[name] = value
    return list(rows.values())  # in time order: the items are, and rows keep their first


class RawEvent(Node):
    def __init__(self, event: ir.Event) -> None:
        super().__init__()
        self.name, self.reads, self.writes = event.name, event.reads, (event.name,)
        self.query = influx.RawQuery(event)

    def process(self, bound: int, emit: Callable[[int, str, Any, str], None]) -> None:
        for row in _rows(self.take(bound)):
            value = self.query.row(row)
            if value is not influx.MISSING:
                emit(row.time, self.name, value, self.name)
        self.final = bound


class WindowedEvent(Node):
    reactive = False

    def __init__(self, event: ir.Event) -> None:
        super().__init__()
        self.name, self.reads, self.writes = event.name, event.reads, (event.name,)
        self.state = influx.EventState(influx.WindowedQuery(event))
        self.draining_until: int | None = None
        # A point is stamped at its window's start: an input changes the windows
        # that began up to one interval before it.
        assert event.window is not None
        self.lead = influx.nanoseconds(event.window.interval)

    def process(self, bound: int, emit: Callable[[int, str, Any, str], None]) -> None:
        for row in _rows(self.take(bound)):
            self.state.add(row)
        if self.draining_until is not None and bound >= _FOREVER:
            points = influx.drain(self.state, self.draining_until)
        else:
            points = self.state.advance(bound)
        for time, value in points:
            emit(time, self.name, value, self.name)
        self.final = bound if bound >= _FOREVER else self.state.final_before(bound)


class Condition(Node):
    """A boolean event with no window: its condition over the newest value of each
    name it reads, a signal that changes only when that value changes."""

    def __init__(self, event: ir.Event) -> None:
        super().__init__()
        self.event = event
        self.name, self.reads, self.writes = event.name, event.reads, (event.name,)
        self.current: dict[str, Any] = {}
        self.value = False
        # evaluated at every change of an input: compiled once
        self.where = None if event.where is None else influx.compiled(event.where)
        self.condition = influx.compiled(event.expr)

    def holds(self) -> bool:
        lookup = self.current.get
        if self.where is not None and self.where(lookup) is not True:
            return False
        return self.condition(lookup) is True

    def process(self, bound: int, emit: Callable[[int, str, Any, str], None]) -> None:
        current = self.current
        for time, items in _instants(self.take(bound)):
            # The condition is a function of the values it reads: evaluated again
            # only where one of them changed (a pedal, a mode, a flag repeat).
            changed, pulses, raised = False, [], set()
            for _, _, name, value, _ in items:
                if name is START:
                    changed = True
                    continue
                if value is True:
                    raised.add(name)
                elif value is False and name in raised:
                    pulses.append(name)  # raised and released at this instant: a pulse
                if not changed:  # the emitter leaves out unchanged values but booleans
                    changed = not same_value(current.get(name, UNSET), value)
                current[name] = value
            for name in pulses:
                # each pulse read as true once, over the instant's other values; then
                # its own value again (false, unless raised once more after it)
                final, current[name] = current[name], True
                self._set(time, emit)
                current[name] = final
            if changed:
                self._set(time, emit)
        self.final = bound

    def _set(self, time: int, emit: Callable[[int, str, Any, str], None]) -> None:
        value = self.holds()
        if value != self.value:
            self.value = value
            emit(time, self.name, value, self.name)


class Transducer(Node):
    """Level-triggered: at every instant an input changes, the transition of the
    current state whose input holds is taken (the first declared); then the new
    state's transitions are tried at the same instant, each transition at most once
    per instant. Emitted events hold at that instant only: one it reads itself
    enables its later steps of the same instant."""

    def __init__(self, transducer: ir.Transducer) -> None:
        super().__init__()
        self.transducer = transducer
        self.name = transducer.name
        # What it emits itself holds at once within its steps, not as an input later.
        self.own = frozenset(transducer.emits)
        inputs = dict.fromkeys(t.input for t in transducer.transitions)
        self.reads = tuple(name for name in inputs if name not in self.own)
        self.writes = (transducer.name, *transducer.emits)
        self.state = transducer.initial
        self.held: dict[str, bool] = {}
        self.steps = 0

    def process(self, bound: int, emit: Callable[[int, str, Any, str], None]) -> None:
        for time, items in _instants(self.take(bound)):
            pulsed = {name for _, _, name, value, _ in items if value is True}
            for _, _, name, value, _ in items:
                self.held[name] = value is True
            self._step(time, pulsed, emit)
        self.final = bound

    def _step(
        self, time: int, pulsed: set[str], emit: Callable[[int, str, Any, str], None]
    ) -> None:
        taken: set[int] = set()
        before = self.state
        while True:
            for index, transition in enumerate(self.transducer.transitions):
                if index in taken or transition.source != self.state:
                    continue
                if self.held.get(transition.input) or transition.input in pulsed:
                    break
            else:
                break
            taken.add(index)
            self.state = transition.dest
            self.steps += 1
            if transition.emit is not None:
                emit(time, transition.emit, True, self.name)
                emit(time, transition.emit, False, self.name)
                if transition.emit in self.own:
                    pulsed = pulsed | {transition.emit}  # a pulse at this instant
        # In exactly one state at every instant: the one the instant's steps end in
        # (states passed through within it hold at no time).
        if self.state != before:
            emit(time, self.name, self.state, self.name)


# ---- consumers: properties and alerts ----


def dataflow_nodes(spec: ir.Spec) -> list[Node]:
    """Events and transducers as nodes, each after every node it reads."""
    nodes: dict[str, Node] = {}
    for event in spec.events:
        if event.window is not None:
            nodes[event.name] = WindowedEvent(event)
        elif event.kind == "boolean":
            nodes[event.name] = Condition(event)
        else:
            nodes[event.name] = RawEvent(event)
    for transducer in spec.transducers:
        nodes[transducer.name] = Transducer(transducer)
    # A boolean event holds or not, from the start: never absent, as a value is
    # before its first sample (docs/semantics.md, "Absent values").
    signals = {e.name for e in spec.events if e.kind == "boolean" and e.window is None}
    signals |= {name for t in spec.transducers for name in t.emits}
    for node in nodes.values():
        if isinstance(node, Condition):
            node.current.update(dict.fromkeys(signals.intersection(node.reads), False))
    producer = {w: key for key, node in nodes.items() for w in node.writes}
    sorter: graphlib.TopologicalSorter[str] = graphlib.TopologicalSorter()
    for key, node in nodes.items():
        sorter.add(key, *(producer[r] for r in node.reads if r in producer and producer[r] != key))
    try:
        order = list(sorter.static_order())
    except graphlib.CycleError as error:
        cycle = " -> ".join(error.args[1])
        raise SpecError(f"events and transducers read each other in a cycle: {cycle}") from None
    return [nodes[key] for key in order]


def reaching(
    nodes: list[Node],
    variables: Iterable[str],
    properties: Iterable[ir.Property],
    state_of: dict[str, str],
) -> dict[str, int]:
    """The properties that read any of `variables`, each with how far before an
    input's time it can change their propositions (ns: windows stamp points at
    their start). `nodes` in dependency order; `state_of`: state -> transducer."""
    lead = dict.fromkeys(variables, 0)
    for node in nodes:
        reached = [lead[name] for name in node.reads if name in lead]
        if reached:
            for name in node.writes:
                lead[name] = max(reached) + node.lead
    found: dict[str, int] = {}
    for prop in properties:
        # A state is reached through its transducer.
        names = {state_of.get(n, n) for n in (*prop.propositions, prop.trigger)}
        leads = [lead[n] for n in names if n in lead]
        if leads:
            found[prop.name] = max(leads)
    return found


class SpecError(ValueError):
    """A resolved spec the runtime cannot run (a cycle through a transducer)."""
