"""The whole spec, executable: messages in, records out (docs/runtime.md).

Standard library only: the replay and the generated ROS 2 node both host this one
implementation. Feed `message(time, topic, msg)` in time order (or out of order by
at most the spec's lateness) and `graph(time, endpoints)` for intrusion detection;
call `end(time)` when the input ends; read `records()`.

Inside, every variable, event and transducer is a node of a dataflow in dependency
order. Each node knows up to which time its output is final (a continuous query's
window is final only when no later run reads it), and a node reads its inputs only
up to the time all of them are final, so the result never depends on how the input
was batched or how late a query ran.
"""

from __future__ import annotations

import graphlib
import heapq
import json
import math
import re
from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Protocol

from rmvdsl.builtins import INFRASTRUCTURE
from rmvdsl.runtime import fields, influx
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.formulas import to_lists
from rmvdsl.runtime.rmtld3 import Monitor, build, continues
from rmvdsl.runtime.uncertain import Uncertain
from rmvdsl.runtime.values import exact_decimal, exact_text
from rmvdsl.runtime.wording import counted

NS = influx.NS
_FOREVER = 1 << 126
LEVELS = ("OK", "INFO", "WARNING", "CRITICAL")
_SEVERITY = {"info": 1, "warn": 2, "crit": 3}
_LOG_LEVEL = {"OK": "info", "INFO": "info", "WARNING": "warn", "CRITICAL": "error"}

Item = tuple[int, int, str, Any, str]  # time, sequence, name, value, source
START = ""  # the name of the item that makes a condition evaluate at the first instant
Record = dict[str, Any]


# The dataflow runs once per this many input instants (and on `decide()`): its output
# does not depend on the batching, and a batch costs the per-run overhead once.
PUMP_EVERY = 64


def seconds(ns: int) -> Fraction:
    return Fraction(ns, NS)


class Host(Protocol):
    """What a host (the replay, the ROS node) does with an action."""

    def act(self, action: ir.Action, context: ActionContext) -> None: ...


@dataclass(frozen=True)
class ActionContext:
    owner_kind: str  # property | alert | intrusion | whitelist | node
    owner: str
    level: str  # a log level: debug, info, warn, error, fatal
    message: str  # the action's message, or the owner's
    record: Record  # what happened, as the runtime reports it


class RecordingHost:
    """Actions as records only: nothing leaves the process."""

    def __init__(self) -> None:
        self.records: list[Record] = []

    def act(self, action: ir.Action, context: ActionContext) -> None:
        self.records.append(action_record(action, context))


def action_record(action: ir.Action, context: ActionContext) -> Record:
    out: Record = {
        "kind": "action",
        "action": action.TAG,
        "owner": context.owner,
        "owner_kind": context.owner_kind,
        "time": context.record.get("time", context.record.get("from")),
        "message": context.message,
    }
    if isinstance(action, ir.Log):
        out["level"] = context.level
    elif isinstance(action, ir.Publish):
        out["topic"] = action.topic
    elif isinstance(action, ir.Post):
        out["url"] = action.url
    elif isinstance(action, ir.Exec):
        out["command"] = [action.command, *action.args]
    elif isinstance(action, ir.Tcp):
        out["address"] = action.address
    return out


def action_text(action: ir.Action, default: str) -> str:
    message = getattr(action, "message", None)
    return message if message is not None else default


def action_level(action: ir.Action, default: str) -> str:
    level = getattr(action, "level", None)
    return level if level is not None else default


# ---- nodes ----


def _take(inbox: list[Item], bound: int) -> list[Item]:
    """Remove the items before `bound` from the heap `inbox`, oldest first (ties in
    arrival order). A heap, because items wait in an inbox until the slowest input
    of the node is final (a query running once a minute) while the others arrive."""
    taken = []
    while inbox and inbox[0][0] < bound:
        taken.append(heapq.heappop(inbox))
    return taken


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
    for time, _, name, value, source in items:
        row = rows.get((time, source))
        if row is None:
            row = rows[(time, source)] = influx.Row(time, {})
        row.fields[name] = value
    return sorted(rows.values(), key=lambda r: r.time)


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
        for time, items in _instants(self.take(bound)):
            pulses, raised = [], set()
            for _, _, name, value, _ in items:
                if name is START:
                    continue
                if value is True:
                    raised.add(name)
                elif value is False and name in raised:
                    pulses.append(name)  # raised and released at this instant: a pulse
                self.current[name] = value
            for name in pulses:
                self.current[name] = True
                self._set(time, emit)
                self.current[name] = False
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
    per instant. Emitted events hold at that instant only."""

    def __init__(self, transducer: ir.Transducer) -> None:
        super().__init__()
        self.transducer = transducer
        self.name = transducer.name
        self.reads = tuple(dict.fromkeys(t.input for t in transducer.transitions))
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
        # In exactly one state at every instant: the one the instant's steps end in
        # (states passed through within it hold at no time).
        if self.state != before:
            emit(time, self.name, self.state, self.name)


# ---- consumers: properties and alerts ----


class PropertyMonitor:
    """One property: the state signal of its propositions, sampled at `rate` (or
    at every change), fed to an RMTLD3 monitor while `trigger` holds."""

    def __init__(self, prop: ir.Property, start: int, initial: frozenset[str]) -> None:
        self.prop = prop
        self.formula = to_lists(prop.formula)
        self.names = frozenset(prop.propositions)
        self.watch = self.names | ({prop.trigger} if prop.trigger != "always" else set())
        self.true: set[str] = set(initial & self.watch)
        self.period = None if prop.rate is None else influx.nanoseconds(1 / prop.rate)
        self.next_tick = None if self.period is None else -(-start // self.period) * self.period
        self.pending_pulses: set[str] = set()
        self.monitor: Monitor | None = None
        self.segments: list[tuple] = []
        self.start = start
        # How far a verdict reads its input ahead and back (seconds): a verdict at s
        # reads the input on [s - past, s + future].
        root = build(self.formula, {})
        self.future, self.past = root.future, root.past
        if self._triggered():
            self._open(start)

    def _triggered(self) -> bool:
        return self.prop.trigger == "always" or self.prop.trigger in self.true

    def _open(self, time: int) -> None:
        self.monitor = Monitor(self.formula)
        if self.period is None:
            self.monitor.step(seconds(time), self.true & self.names)

    def _close(self, time: int) -> None:
        if self.monitor is not None:
            self.monitor.end(seconds(time))
            self.segments.extend(self.monitor.verdicts())
            self.monitor = None

    def instant(self, time: int, changes: list[tuple[str, Any]]) -> None:
        self.ticks_before(time)
        was = self._triggered()
        pulses = set()
        for name, value in changes:
            if name not in self.watch:
                continue
            if value is True:
                self.true.add(name)
            else:
                if name in self.true and any(n == name and v is True for n, v in changes):
                    pulses.add(name)
                self.true.discard(name)
        now = self._triggered()
        if was and not now:
            self._close(time)
        elif now and not was:
            self._open(time)
        if self.monitor is None:
            return
        if self.period is None:
            self.monitor.step(seconds(time), self.true & self.names, pulses & self.names)
        else:
            self.pending_pulses |= pulses

    def ticks_before(self, bound: int) -> None:
        """Samples at the rate's ticks before `bound` (all that happened up to a
        tick is known once the input is final past it)."""
        if self.period is None or self.next_tick is None or self.next_tick >= bound:
            return
        state = self.true & self.names
        if self.monitor is not None:
            self.monitor.step(seconds(self.next_tick), state, self.pending_pulses & self.names)
        self.pending_pulses = set()
        # The later ticks repeat that state without pulses, which only tells the
        # monitor that time has passed: the last of them says it for all (a gap of
        # years between two stamps costs one step, not a step per tick).
        last = self.next_tick + (bound - 1 - self.next_tick) // self.period * self.period
        if last > self.next_tick and self.monitor is not None:
            self.monitor.step(seconds(last), state, frozenset())
        self.next_tick = last + self.period

    def advance(self, bound: int) -> None:
        """Nothing changed before `bound`: the monitor knows its input up to there
        (a rate's ticks say it for a sampled property)."""
        if self.period is None and self.monitor is not None and bound > self.start:
            self.monitor.advance(seconds(bound))

    def verdicts(self) -> list[tuple]:
        if self.monitor is not None:
            self.segments.extend(self.monitor.verdicts())
        out, self.segments = self.segments, []
        return out

    def end(self, time: int) -> None:
        self.ticks_before(time + 1)
        self._close(time)


def kapacitor_level(levels: Sequence[ir.AlertLevel], current: int, lookup: Any) -> int:
    """Kapacitor's AlertNode.determineLevel: a level at or above the current one
    whose condition holds; else the current one while its reset does not hold;
    else the highest level below that holds; else OK."""
    by_rank = {_SEVERITY[level.severity]: level for level in levels}

    def holds(rank: int) -> bool:
        level = by_rank.get(rank)
        return level is not None and influx.evaluate(level.condition, lookup) is True

    for rank in range(3, max(current, 1) - 1, -1):
        if holds(rank):
            return rank
    reset = by_rank[current].reset if current in by_rank else None
    if reset is not None and influx.evaluate(reset, lookup) is not True:
        return current
    for rank in range(current, 0, -1):
        if holds(rank):
            return rank
    return 0


class AlertState:
    def __init__(self, alert: ir.Alert) -> None:
        self.alert = alert
        self.reads = frozenset(alert.reads)
        self.current: dict[str, Any] = {}
        self.level = 0

    def instant(self, time: int, changes: list[tuple[str, Any]]) -> Record | None:
        touched = False
        for name, value in changes:
            if name in self.reads:
                self.current[name] = value
                touched = True
        if not touched:
            return None
        previous = self.level
        self.level = kapacitor_level(self.alert.levels, previous, self.current.get)
        if self.level == previous and (self.alert.state_changes_only or self.level == 0):
            return None
        if self.level == 0 and self.alert.no_recoveries:
            return None
        return {
            "kind": "alert",
            "alert": self.alert.name,
            "id": self.alert.id,
            "time": seconds(time),
            "level": LEVELS[self.level],
            "previous": LEVELS[previous],
            "message": self.alert.message,
            "values": {n: self.current[n] for n in self.alert.reads if n in self.current},
        }


# ---- intrusion detection ----


@dataclass(frozen=True)
class Endpoint:
    node: str
    topic: str
    role: str  # publisher | subscriber


def _matches(patterns: Iterable[ir.Pattern], name: str) -> bool:
    return any(re.match(p.regex, name) for p in patterns)


def can_refuse(spec: ir.Spec) -> bool:
    """Whether any endpoint could be an intrusion (else the graph need not be read)."""
    return bool(spec.whitelists or spec.nodes or spec.intrusion.default == "deny")


def verdict_of(
    spec: ir.Spec, endpoint: Endpoint, ros_version: int | None = None
) -> tuple[str, Any] | None:
    """Why an endpoint is not allowed (and the rule that refused it), or None, on a
    system of `ros_version` (default: the spec's)."""
    if _matches(spec.intrusion.ignore_nodes, endpoint.node):
        return None
    publisher = endpoint.role == "publisher"
    lists = [w for w in spec.whitelists if re.match(w.topic.regex, endpoint.topic)]
    intrusion = spec.intrusion
    if intrusion.infrastructure == "ros" and not lists:
        given = INFRASTRUCTURE.get(ros_version or spec.ros.version, {})
        infrastructure = given.get(endpoint.role, ())
    else:
        infrastructure = ()
    if endpoint.topic in infrastructure:
        return None  # ROS's own, which every node uses (docs/runtime.md, "Intrusions")
    # The reason says what and why; the record and the action's text say who.
    for rule in lists:
        allowed = rule.publishers if publisher else rule.subscribers
        if allowed is not None and not _matches(allowed, endpoint.node):
            return f"not in the {endpoint.role}s allowed on {rule.topic.text}", rule
    if not lists and intrusion.default == "deny":
        does = "publishes on" if publisher else "subscribes to"
        return f"{does} {endpoint.topic}, which has no whitelist, and the default is deny", None
    for node_rule in spec.nodes:
        if re.match(node_rule.node.regex, endpoint.node):
            allowed = node_rule.publishes if publisher else node_rule.subscribes
            verb = "publish" if publisher else "subscribe"
            if allowed is not None and not _matches(allowed, endpoint.topic):
                rule_name = node_rule.node.text
                by = f" (node {rule_name})" if rule_name != endpoint.node else ""
                return f"may not {verb} on {endpoint.topic}{by}", node_rule
    return None


# ---- the runtime ----


class Runtime:
    """The executable spec. `record` chooses the optional record kinds: `state`
    and `event` (value points and boolean changes) by default, `variable` too when
    asked for."""

    def __init__(
        self,
        spec: ir.Spec,
        host: Host | None = None,
        record: Iterable[str] = ("state", "event"),
        skip: Iterable[str] = (),
        ros_version: int | None = None,
    ) -> None:
        self.spec = spec
        # The ROS the monitor runs on (a ROS 2 node for a spec written for noetic):
        # what ROS itself has every node use depends on it.
        self.ros_version = ros_version or spec.ros.version
        self.host: Host = host or RecordingHost()
        self.recorded = frozenset(record)
        self.counters: Counter[str] = Counter()
        self.out: list[Record] = []
        self.sequence = 0
        self.started: int | None = None
        self.now = -_FOREVER  # the newest time fed to the dataflow
        self.complete_before = -_FOREVER  # a live host said no input comes before this
        self.instants = 0  # distinct input times so far
        self.newest = -_FOREVER  # the newest time seen (some may still be held)
        self.lateness = max((influx.nanoseconds(p.lateness) for p in spec.properties), default=0)
        self.held: list[tuple[int, int, str, Any]] = []
        self.by_topic: dict[str, list[tuple[ir.Variable, Callable[[Any], Any]]]] = {}
        topic_names = {t.name: t.ros_name for t in spec.topics}
        self.topic_origin = {t.ros_name: t.origin for t in spec.topics}
        self.stamped = fields.stamped_topics(spec.topics)
        skipped = frozenset(skip)  # variables the input cannot give (the replay checked)
        for variable in spec.variables:
            variables = self.by_topic.setdefault(topic_names[variable.topic], [])
            if variable.name not in skipped:
                variables.append((variable, fields.reader(variable)))
        self.nodes = _dataflow(spec)
        self.subscribers: dict[str, list[Node]] = {}
        for node in self.nodes:
            for name in node.reads:
                self.subscribers.setdefault(name, []).append(node)
        self.producer: dict[str, Node] = {n: node for node in self.nodes for n in node.writes}
        self.upstream = [(node, self._producers(node.reads)) for node in self.nodes]
        self.properties: list[PropertyMonitor] = []
        self.alerts = [AlertState(a) for a in spec.alerts]
        self.state_of = {s: t.name for t in spec.transducers for s in t.states}
        self.current_states = {t.name: t.initial for t in spec.transducers}
        wanted = (
            {n for p in spec.properties for n in p.propositions}
            | {p.trigger for p in spec.properties}
            | {n for a in spec.alerts for n in a.reads}
        )
        # A state is read through its transducer, whose items carry the state's name.
        self.consumed = frozenset(self.state_of.get(n, n) for n in wanted)
        self.consumer_inbox: list[Item] = []
        self.consumer_upstream = self._producers(self.consumed)
        self.pending_segments: dict[str, list[Any]] = {}
        # Late input (docs/runtime.md, "Late input"): per property, the verdict
        # time it made unknown; the end of the verdicts given out so far.
        self.uncertain = {p.name: Uncertain() for p in spec.properties}
        self.given_to: dict[str, tuple[Fraction, bool]] = {}
        self.last_on: dict[str, int] = {}  # the newest message fed, per topic
        # Intervals that end when their topic publishes again, and how long after.
        self.until_next: dict[str, list[tuple[list[Any], Fraction]]] = {}
        self.intrusions: dict[Endpoint, str] = {}
        self.reported: set[str] = set()  # counters of lost input already reported

    # ---- input ----

    def message(self, time: int, topic: str, message: Any) -> None:
        """One message of a ROS topic received at `time` (integer nanoseconds); a
        topic with `time = header` takes its time from the message's stamp."""
        self.counters["messages"] += 1
        if topic not in self.by_topic:
            self.counters["messages on topics the spec does not read"] += 1
            return
        if topic in self.stamped:
            try:
                time = fields.stamp(message)
            except fields.FieldError as error:
                self.damaged(time, topic, str(error))
                return
        if self.lateness:
            heapq.heappush(self.held, (time, self.sequence, topic, message))
            self.sequence += 1
            self.newest = max(self.newest, time)
            while self.held and self.held[0][0] <= self.newest - self.lateness:
                when, _, held_topic, held_message = heapq.heappop(self.held)
                self._ingest(when, held_topic, held_message)
            return
        self._ingest(time, topic, message)

    def time_of(self, time: int, topic: str, message: Any) -> int:
        """The time `message` would take (its stamp on a `time = header` topic, else
        `time`), for a host that orders what it holds before feeding it."""
        if topic in self.stamped and topic in self.by_topic:
            try:
                return fields.stamp(message)
            except fields.FieldError:
                return time  # `message` reports it
        return time

    def start(self, time: int) -> None:
        """The run begins at `time` before any message (a live node starts before
        the topics publish): the transducers are in their initial states and every
        condition is evaluated over values not there yet."""
        if self.started is None:
            self._begin(time)
            self.now = max(self.now, time)
            self.instants += 1

    def _ingest(self, time: int, topic: str, message: Any) -> None:
        if time < self.now or time < self.complete_before:
            late = exact_text(seconds(max(self.now, self.complete_before) - time))
            text = (
                f"{topic}: a message came {late} s late, later than the spec's lateness "
                "allows: dropped (set `lateness` on a property)"
            )
            self._input_lost(time, topic, f"late messages dropped: {topic}", 1, text)
            self._late_input(time, topic)
            return
        if self.started is None:
            self._begin(time)
        self.last_on[topic] = time
        if self.until_next:
            for interval, past in self.until_next.pop(topic, ()):
                interval[1] = seconds(time) + past
        if time > self.now:
            self.now = time
            self.instants += 1
            if self.instants % PUMP_EVERY == 0:
                self._pump(time)
        for variable, read in self.by_topic[topic]:
            try:
                value = read(message)
            except fields.FieldError as error:
                self._field_error(time, topic, variable, str(error))
                continue
            if value is fields.MISSING:
                self.counters[f"no sample: {variable.name}"] += 1
                continue
            self._emit(time, variable.name, value, topic)

    def _late_input(self, time: int, topic: str) -> None:
        """A message of `topic` at `time` came after the monitor had passed its time:
        every property reading the topic is unknown where its verdict reads the
        input from `time` to the newest the monitor had (and on, until the topic
        publishes again, if it has not since), and what was given out there is
        revised."""
        assert self.started is not None  # a message is late only after others
        noticed = seconds(max(self.now, self.complete_before))
        superseded = self.last_on.get(topic, -_FOREVER) > time
        reach = self._reach(topic)
        for monitor in self.properties:
            name = monitor.prop.name
            if name not in reach:
                continue
            # A window's point is stamped up to an interval before its input and
            # holds until the next: the stretch widens by the lead on both sides.
            lead = seconds(reach[name] + (monitor.period or 0))
            low = max(seconds(time) - lead - monitor.future, seconds(self.started))
            after = lead + monitor.past
            high = noticed + after if superseded else None
            interval = self.uncertain[name].add(low, high)
            if not superseded:
                self.until_next.setdefault(topic, []).append((interval, after))
            self._revise(name, low, high)

    def _reach(self, topic: str) -> dict[str, int]:
        """The properties that read `topic`, each with how far before an input's
        time it can change their propositions (windows stamp points at their start)."""
        lead = {variable.name: 0 for variable, _ in self.by_topic.get(topic, ())}
        for node in self.nodes:  # in dependency order
            reached = [lead[name] for name in node.reads if name in lead]
            if reached:
                for name in node.writes:
                    lead[name] = max(reached) + node.lead
        found: dict[str, int] = {}
        for monitor in self.properties:
            prop = monitor.prop
            # A state is reached through its transducer.
            names = {self.state_of.get(n, n) for n in (*prop.propositions, prop.trigger)}
            leads = [lead[n] for n in names if n in lead]
            if leads:
                found[prop.name] = max(leads)
        return found

    def _revise(self, name: str, low: Fraction, high: Fraction | None) -> None:
        """The verdicts given out on [low, high] are unknown: one record says so,
        marked `revised` (it overlaps records before it)."""
        given = self.given_to.get(name)
        if given is None or low > given[0] or (low == given[0] and not given[1]):
            return
        if name in self.pending_segments:
            self._flush_segment(name)
        stop, stop_closed = given if high is None or high >= given[0] else (high, True)
        self.pending_segments[name] = [low, stop, True, stop_closed, "unknown", True]

    def damaged(self, time: int, topic: str, reason: str) -> None:
        """A message that could not be decoded."""
        text = f"{topic}: a message cannot be decoded: {reason}"
        self._input_lost(time, topic, f"damaged messages: {topic}", 1, text)

    def lost(self, time: int, topic: str, count: int) -> None:
        """Messages the transport lost (a host that sees gaps in the publishers'
        sequence numbers reports them)."""
        text = (
            f"{topic}: {counted(count, 'message')} lost before the monitor could read "
            f"{'it' if count == 1 else 'them'} "
            "(a deeper `depth` in the topic's qos block keeps more waiting)"
        )
        self._input_lost(time, topic, f"lost messages: {topic}", count, text)

    def _field_error(self, time: int, topic: str, variable: ir.Variable, reason: str) -> None:
        text = f"{topic}: `{variable.name}` cannot be read: {reason}"
        counter = f"messages not matching the spec: {variable.name}"
        self._input_lost(time, topic, counter, 1, text, variable.origin)

    def _input_lost(
        self, time: int, topic: str, counter: str, count: int, text: str, origin: str = ""
    ) -> None:
        """Input the runtime could not use: always counted, reported once per
        counter (a topic's, or a variable's)."""
        self.counters[counter] += count
        if counter not in self.reported:
            self.reported.add(counter)
            self._note(time, text, topic, origin)

    def _note(self, time: int, text: str, topic: str, origin: str = "") -> None:
        """A diagnostic record, at the spec's declaration that the input disagrees
        with (the topic's, unless a more precise one is given)."""
        origin = origin or self.topic_origin.get(topic, "")
        self.out.append(
            {"kind": "diagnostic", "time": seconds(time), "origin": origin, "message": text}
        )

    def _begin(self, time: int) -> None:
        self.started = time
        # Each condition is evaluated at the first instant, changed input or not:
        # `not E` holds from the start while E does not.
        for node in self.nodes:
            if isinstance(node, Condition):
                heapq.heappush(node.inbox, (time, 0, START, None, ""))
        initial = frozenset(t.initial for t in self.spec.transducers)
        self.properties = [PropertyMonitor(p, time, initial) for p in self.spec.properties]
        for transducer in self.spec.transducers:
            if "state" in self.recorded:
                self.out.append(
                    {"kind": "state", "transducer": transducer.name, "time": seconds(time),
                     "state": transducer.initial}
                )  # fmt: skip

    def graph(self, time: int, endpoints: Iterable[Endpoint]) -> None:
        """A snapshot of the ROS graph: every endpoint present at `time`. An
        intrusion is reported when it appears and when it ends."""
        present: dict[Endpoint, str] = {}
        rules: dict[Endpoint, Any] = {}
        for endpoint in endpoints:
            found = verdict_of(self.spec, endpoint, self.ros_version)
            if found is not None:
                present[endpoint], rules[endpoint] = found
        for endpoint, reason in present.items():
            if endpoint not in self.intrusions:
                self._intrusion(time, endpoint, reason, rules[endpoint], "start")
        for endpoint, reason in list(self.intrusions.items()):
            if endpoint not in present:
                self._intrusion(time, endpoint, reason, None, "end")
        self.intrusions = present

    def _intrusion(self, time: int, endpoint: Endpoint, reason: str, rule: Any, phase: str) -> None:
        record = {
            "kind": "intrusion", "time": seconds(time), "phase": phase, "node": endpoint.node,
            "topic": endpoint.topic, "role": endpoint.role, "reason": reason,
        }  # fmt: skip
        self.out.append(record)
        if phase != "start":
            return
        self.counters["intrusions"] += 1
        actions = (*(rule.actions if rule is not None else ()), *self.spec.intrusion.actions)
        owner = "intrusion" if rule is None else type(rule).__name__.lower()
        for action in actions:
            text = action_text(action, f"intrusion: {endpoint.node} {reason}")
            context = ActionContext(
                owner, endpoint.node, action_level(action, "error"), text, record
            )
            self._act(action, context)

    def end(self, time: int | None = None) -> None:
        """The input ends at `time` (default: the newest message)."""
        while self.held:
            when, _, topic, message = heapq.heappop(self.held)
            self._ingest(when, topic, message)
        if self.started is not None:
            self._finish(self.now if time is None else max(time, self.now))
        for name, value in sorted(self.counters.items()):
            self.out.append({"kind": "counter", "name": name, "value": value})

    def _finish(self, time: int) -> None:
        for node in self.nodes:
            if isinstance(node, WindowedEvent):
                node.draining_until = time + 1
        self._pump(_FOREVER)
        for monitor in self.properties:
            monitor.end(time)
            self._verdicts(monitor)
        for name in list(self.pending_segments):
            self._flush_segment(name)

    def records(self) -> list[Record]:
        """The records produced since the last call, in the order they were decided."""
        out, self.out = self.out, []
        return out

    def _act(self, action: ir.Action, context: ActionContext) -> None:
        self.host.act(action, context)
        if isinstance(self.host, RecordingHost):  # its records go out in order
            self.out.extend(self.host.records)
            self.host.records.clear()

    # ---- the dataflow ----

    def _producers(self, names: Iterable[str]) -> list[Node]:
        """The nodes that write any of `names` (variables have none)."""
        found = (self.producer[n] for n in names if n in self.producer)
        return list(dict.fromkeys(found))

    def _emit(self, time: int, name: str, value: Any, source: str) -> None:
        self.sequence += 1
        # A window's point is stamped at the window's start, which can precede the
        # first message of the run: it takes effect at the run's first instant
        # (nothing happens before the run starts); its record keeps the stamp.
        at = time if self.started is None or time >= self.started else self.started
        item = (at, self.sequence, name, value, source)
        for node in self.subscribers.get(name, ()):
            heapq.heappush(node.inbox, item)
        if name in self.consumed:
            heapq.heappush(self.consumer_inbox, item)
        producer = self.producer.get(name)
        if producer is None:
            if "variable" in self.recorded:
                self.out.append(
                    {"kind": "variable", "time": seconds(time), "name": name, "value": value}
                )
        elif isinstance(producer, Transducer) and name == producer.name:
            if "state" in self.recorded:
                self.out.append(
                    {"kind": "state", "transducer": name, "time": seconds(time), "state": value}
                )
        elif "event" in self.recorded:
            self.out.append({"kind": "event", "time": seconds(time), "name": name, "value": value})

    def _pump(self, input_final: int) -> None:
        """Let every node compute what its inputs have made final (in dependency
        order, so a node's upstream nodes are already up to date)."""
        emit = self._emit
        for node, upstream in self.upstream:
            bound = input_final
            for producer in upstream:
                if producer.final < bound:
                    bound = producer.final
            if node.inbox or not node.reactive:
                node.process(bound, emit)
            else:
                node.final = bound  # nothing to do until an input arrives
        bound = input_final
        for producer in self.consumer_upstream:
            if producer.final < bound:
                bound = producer.final
        self._consume(bound)

    def _consume(self, bound: int) -> None:
        if self.consumer_inbox:
            taken = _take(self.consumer_inbox, bound)
            for time, items in _instants(taken):
                changes = self._changes(items)
                for monitor in self.properties:
                    monitor.instant(time, changes)
                for alert in self.alerts:
                    record = alert.instant(time, changes)
                    if record is not None:
                        self._alert(alert.alert, record)
        for monitor in self.properties:
            if bound < _FOREVER:
                monitor.ticks_before(bound)
            self._verdicts(monitor)

    def _changes(self, items: list[Item]) -> list[tuple[str, Any]]:
        """Items as proposition changes: a transducer entering a state makes its
        old state false and the new one true."""
        changes: list[tuple[str, Any]] = []
        for _, _, name, value, _ in items:
            old = self.current_states.get(name)
            if old is None:
                changes.append((name, value))
                continue
            self.current_states[name] = value
            changes.extend(((old, False), (value, True)))
        return changes

    def _alert(self, alert: ir.Alert, record: Record) -> None:
        self.out.append(record)
        self.counters[f"alerts: {alert.name}"] += 1
        for action in alert.actions:
            text = action_text(action, alert.message)
            level = action_level(action, _LOG_LEVEL[record["level"]])
            context = ActionContext("alert", alert.name, level, text, record)
            self._act(action, context)

    def _verdicts(self, monitor: PropertyMonitor) -> None:
        name = monitor.prop.name
        uncertain = self.uncertain[name]
        for given in monitor.verdicts():
            self.given_to[name] = (given[1], given[3])
            for start, stop, start_closed, stop_closed, verdict in uncertain.mask(given):
                self._verdict(monitor.prop, start, stop, start_closed, stop_closed, verdict)

    def _verdict(
        self,
        prop: ir.Property,
        start: Any,
        stop: Any,
        start_closed: bool,
        stop_closed: bool,
        verdict: str,
    ) -> None:
        """One segment in order: joined to the one before when it continues it."""
        name = prop.name
        value = verdict.split(" ")[0]
        segment = [start, stop, start_closed, stop_closed, value]
        pending = self.pending_segments.get(name)
        if pending is not None and continues(pending, segment):
            pending[1], pending[3] = stop, stop_closed
            return
        if pending is not None:
            self._flush_segment(name)
        self.pending_segments[name] = segment
        if value == "false":
            self._violated(prop, segment)

    def _violated(self, prop: ir.Property, segment: list[Any]) -> None:
        self.counters[f"violations: {prop.name}"] += 1
        record = {"kind": "violation", "property": prop.name, "from": segment[0]}
        for action in prop.actions:
            text = action_text(action, f"{prop.name} violated")
            self._act(
                action,
                ActionContext("property", prop.name, action_level(action, "error"), text, record),
            )

    def _flush_segment(self, name: str) -> None:
        start, stop, start_closed, stop_closed, value, *revised = self.pending_segments.pop(name)
        bounds = ("[" if start_closed else "(") + ("]" if stop_closed else ")")
        record = {
            "kind": "verdict", "property": name, "verdict": value, "from": start,
            "to": stop, "bounds": bounds,
        }  # fmt: skip
        if revised:
            record["revised"] = True
        self.out.append(record)

    def decide(self, complete_before: int | None = None) -> None:
        """Compute everything the input so far decides (a live host calls this on a
        timer and after messages, so output never waits for the next batch).

        A live host that times messages by its own clock (every topic timed by
        receipt, no lateness) knows more: no message can come before its clock's
        `complete_before`, so the input up to there is final even in silence (a
        property sampled at a rate, waiting 2 s for something, fails when 2 s pass
        with no message)."""
        if self.started is None:
            return
        bound = self.now
        if complete_before is not None and not self.stamped and not self.lateness:
            self.complete_before = max(self.complete_before, complete_before)
            bound = max(bound, self.complete_before)
        self._pump(bound)
        # Silence decides too: a state that holds while time passes (docs/runtime.md,
        # "Deciding as time passes"). Only what every node has made final counts.
        final = min((p.final for p in self.consumer_upstream), default=bound)
        for monitor in self.properties:
            monitor.advance(min(bound, final))
            self._verdicts(monitor)


def _dataflow(spec: ir.Spec) -> list[Node]:
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


class SpecError(ValueError):
    """A resolved spec the runtime cannot run (a cycle through a transducer)."""


def to_json(record: Record) -> str:
    """One record as one line of JSON; times and other fractions as exact decimals
    (a quotient such as "1/3" as a string where no decimal is exact), floats that
    JSON cannot hold as strings ("nan", "inf", "-inf")."""
    return _json_value(record)


def _json_value(value: Any) -> str:
    kind = type(value)
    if kind is str:
        return _json_string(value)
    if kind is Fraction:
        text = exact_decimal(value)
        return text if text is not None else f'"{value}"'
    if kind is bool or value is None:
        return "true" if value is True else "false" if value is False else "null"
    if kind is int:
        return str(value)
    if kind is float:
        return repr(value) if math.isfinite(value) else f'"{value!r}"'
    if isinstance(value, dict):
        items = (f"{_json_string(str(k))}: {_json_value(v)}" for k, v in value.items())
        return "{" + ", ".join(items) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_json_value(v) for v in value) + "]"
    return _json_string(str(value))


_json_string = json.JSONEncoder(ensure_ascii=False).encode
