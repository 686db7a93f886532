"""Where two runs of one recording join (docs/fleet.md, "Long recordings"): the part
of a Runtime's state that decides everything it does from a point on, in a canonical
form. A run that started late (a chunk's lead-in) and the run that read the whole
recording are interchangeable from a point at which their keys are equal: from
there on they are the same machine fed the same messages.

The key leaves out only what cannot change a later record: counters (added up per
chunk), history older than every horizon and window, sequence numbers (their order
is kept), and when the run started once that is further back than anything reads.
Whatever it cannot put in canonical form makes the key unmatchable (None): the join
is then made by reading on, never by guessing.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from fractions import Fraction
from typing import Any

from rmvdsl.runtime import influx, rates
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.dataflow import Condition, Item, Node, RawEvent, Transducer, WindowedEvent
from rmvdsl.runtime.properties import PropertyMonitor
from rmvdsl.runtime.records import NS, seconds
from rmvdsl.runtime.rmtld3 import Ever, Monitor, facts
from rmvdsl.runtime.signal import Signal

# Verdicts are compared from one nanosecond before the point from which both runs
# agree, so that a segment starting there starts at the same time in both.
MARGIN = Fraction(1, NS)


class _Unmatched(Exception):
    """A part of the state with no canonical form."""


def reach(spec: ir.Spec) -> int:
    """How far back from now anything the runtime computes reads (ns): the longest
    horizon plus the longest stretch a windowed query's runs read."""
    # A property with no bound back keeps only a finite history (its window) and the
    # value pending in its `since` nodes, which the seam key holds (`_monitor`).
    horizons = [facts(p.formula).reach for p in spec.properties]
    windows = []
    for event in spec.events:
        if event.window is not None:
            every, span = ir.resampling(
                event.window.interval, event.resample_every, event.resample_for
            )
            windows.append(span + 2 * event.window.interval + every)
    longest = max(horizons, default=Fraction(0)) + max(windows, default=Fraction(0))
    # A declared max_rate counts messages over a window of its own.
    longest = max([longest, *(rates.window(t.max_rate) for t in spec.topics if t.max_rate)])
    return influx.nanoseconds(longest) + 1


def lead_in(spec: ir.Spec) -> int:
    """How long before a chunk its run starts reading (ns): twice the reach, and at
    least a second. Any lead-in gives exact results; a longer one lets more chunks
    join without reading on."""
    return max(NS, 2 * reach(spec))


def seam_key(runtime: Any, endpoints: Iterable[Any]) -> str | None:
    """The key of `runtime` (a Runtime just after `decide()`), with the graph's
    `endpoints` its host has seen; None when a part has no canonical form."""
    try:
        state = (*_runtime(runtime, reach(runtime.spec)), sorted(map(repr, endpoints)))
    except _Unmatched:
        return None
    return hashlib.sha256(repr(state).encode()).hexdigest()


def _runtime(runtime: Any, back: int) -> tuple[Any, ...]:
    if runtime.held:
        raise _Unmatched  # messages held for lateness: no canonical form of a message
    started = runtime.started
    return (
        # When the run started matters only while something still reads back to it.
        None if started is None or started <= runtime.now - back else started,
        runtime.now,
        runtime.complete_before,
        runtime.newest,
        sorted(runtime.current_states.items()),
        sorted(runtime.last_on.items()),
        sorted(runtime.reported),
        sorted((topic, limit.state()) for topic, limit in runtime.rates.items()),
        sorted((repr(e), reason) for e, reason in runtime.intrusions.items()),
        sorted(_waiting(topic, waiting) for topic, waiting in runtime.until_next.items()),
        [(a.level, _mapping(a.current)) for a in runtime.alerts],
        _inbox(runtime.consumer_inbox),
        [_node(node) for node in runtime.nodes],
        [_property(monitor) for monitor in runtime.properties],
        _segments(runtime.segments, runtime.properties),
    )


def _waiting(topic: str, waiting: list[tuple[list[Any], Any]]) -> tuple[Any, ...]:
    """Intervals of unknown verdicts that end when `topic` publishes again."""
    return (topic, tuple((_plain(interval), past) for interval, past in waiting))


def _plain(value: Any) -> Any:
    """A value in a form whose repr is its identity."""
    if value is None or isinstance(value, bool | int | str | Fraction):
        return value
    if isinstance(value, float):
        return ("float", value.hex())
    if isinstance(value, list | tuple):
        return tuple(_plain(v) for v in value)
    if isinstance(value, dict):
        return _mapping(value)
    raise _Unmatched


def _mapping(mapping: dict[Any, Any]) -> tuple[Any, ...]:
    return tuple(sorted((repr(k), _plain(v)) for k, v in mapping.items()))


def _inbox(items: list[Item]) -> tuple[Any, ...]:
    """A heap of items, in the order it gives them out, without sequence numbers."""
    return tuple((t, name, _plain(value), source) for t, _, name, value, source in sorted(items))


def _node(node: Node) -> tuple[Any, ...]:
    common = (node.name, node.final, _inbox(node.inbox))
    if isinstance(node, Condition):
        return (*common, _mapping(node.current), node.value)
    if isinstance(node, Transducer):
        return (*common, node.state, sorted(node.held.items()))
    if isinstance(node, RawEvent):
        streams = [(s.name, _plain(s.previous), _plain(s.buffer), _plain(s.total))
                   for s in node.query.streams.values()]  # fmt: skip
        return (*common, streams)
    if isinstance(node, WindowedEvent):
        state = node.state
        rows = [(row.time, _mapping(row.fields)) for row in state.rows]
        written = _mapping(state.written)
        return (*common, rows, written, state.next_run, state.final, node.draining_until)
    raise _Unmatched


def _property(monitor: PropertyMonitor) -> tuple[Any, ...]:
    return (
        sorted(monitor.true), monitor.next_tick, sorted(monitor.pending_pulses),
        None if monitor.monitor is None else _monitor(monitor.monitor),
        [tuple(s) for s in monitor.segments],
    )  # fmt: skip


def _monitor(monitor: Monitor) -> tuple[Any, ...]:
    """An RMTLD3 monitor after a flush: its input from a horizon (and a margin) before
    what it knows on, and how far it has given out verdicts. A verdict still to come
    reads nothing older."""
    if monitor.start is None:
        return ("not started", tuple(monitor.pending))
    if monitor.changes or monitor.pending or monitor.late:
        raise _Unmatched
    low = monitor.known - monitor.horizon - 1  # MARGIN: the monitor counts nanoseconds
    signals = tuple(
        (name, _signal(prop.signal, low)) for name, prop in sorted(monitor.props.items())
    ) + tuple(  # what each `since` with no bound carries over from before `low`
        (index, _signal(node.pending, low))
        for index, node in enumerate(monitor.order) if isinstance(node, Ever)
    )  # fmt: skip
    return (
        max(monitor.start, low), monitor.known, monitor.written, monitor.emitted,
        monitor.emitted_point, sorted(monitor.state), sorted(monitor.written_state),
        sorted(monitor.written_pulses), signals,
    )  # fmt: skip


def _signal(signal: Signal, low: Any) -> tuple[Any, ...]:
    """The signal from `low` on: its value at `low`, then its breakpoints."""
    if signal.starts[0] > low:
        head: tuple[Any, ...] = ("from", signal.starts[0])
        low = signal.starts[0]
    else:
        head = ("at", signal.at(low), signal.right_of(low))
    index = signal.index(low)
    tail = tuple(
        (signal.starts[k], signal.points[k], signal.opens[k])
        for k in range(index, len(signal.starts)) if signal.starts[k] > low
    )  # fmt: skip
    return (head, tail)


def _segments(segments: Any, monitors: list[PropertyMonitor]) -> tuple[Any, ...]:
    """The verdicts given out: each property's open segment (its start only where both
    runs' verdicts agree: the join takes the start from the run before), how far the
    verdicts are out, and the intervals late input made unknown that can still cut."""
    out = []
    for monitor in monitors:
        name = monitor.prop.name
        agree = _agree_from(monitor)
        pending = segments.pending.get(name)
        if pending is not None:
            start, stop, start_closed, *rest = pending
            if agree is None or start < agree:
                start = start_closed = None
            pending = (start, start_closed, stop, *rest)
        given = segments.given_to.get(name)
        intervals = [
            tuple(i) for i in segments.uncertain[name].intervals
            if i[1] is None or agree is None or i[1] >= agree
        ]  # fmt: skip
        out.append((name, pending, given, intervals))
    return tuple(out)


def _agree_from(monitor: PropertyMonitor) -> Any:
    """From when two runs whose keys are equal give the same verdicts."""
    inner = monitor.monitor
    if inner is None or inner.start is None:
        return None
    return max(seconds(inner.start), seconds(inner.known) - monitor.future - MARGIN)


def pending_starts(runtime: Any) -> dict[str, tuple[Any, bool]]:
    """Each property's open verdict segment's start (time in seconds, closed)."""
    return {name: (p[0], p[2]) for name, p in runtime.segments.pending.items()}
