"""What the runtime reports besides verdicts' values: lost and damaged input
(counted, reported once per counter), intrusions from graph snapshots, alerts,
violations and the actions they run, and the records out (a part of Runtime)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from fractions import Fraction
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.dataflow import _FOREVER, Node, reaching
from rmvdsl.runtime.intrusions import Endpoint, verdict_of
from rmvdsl.runtime.properties import PropertyMonitor
from rmvdsl.runtime.readings import Readers
from rmvdsl.runtime.records import (
    NS,
    ActionContext,
    Host,
    Record,
    RecordingHost,
    action_level,
    action_text,
    seconds,
)
from rmvdsl.runtime.values import exact_text
from rmvdsl.runtime.verdicts import Segments
from rmvdsl.runtime.wording import counted

# A stamp this far ahead of its message's receipt is not believed: taken as the
# message's time it would make every later message late (docs/runtime.md).
STAMP_AHEAD = 10 * NS

_LOG_LEVEL = {"OK": "info", "INFO": "info", "WARNING": "warn", "CRITICAL": "error"}


def unread(listed: int, read: int) -> tuple[str, str]:
    """The counter and the words for a recording that gave other than it lists."""
    if read < listed:
        lost = listed - read
        return "messages the recording lists but cannot be read", (
            f"the recording lists {counted(listed, 'message', grouped=True)} on the topics "
            f"the spec reads, and {read:,} could be read: {lost:,} "
            f"{'is' if lost == 1 else 'are'} lost to damage (what "
            f"{'it' if lost == 1 else 'they'} would have changed is not known)"
        )  # fmt: skip
    return "messages the recording does not list", (
        f"the recording lists {counted(listed, 'message', grouped=True)} on the topics the "
        f"spec reads, but gave {read:,}: its index does not match its data"
    )


class Reporting:
    """Runtime's records and actions (Runtime's state, which this is a part of)."""

    spec: ir.Spec
    ros_version: int
    host: Host
    counters: Counter[str]
    reported: set[str]
    out: list[Record]
    topic_origin: dict[str, str]
    intrusions: dict[Endpoint, str]
    segments: Segments
    last_on: dict[str, int]
    stamped: frozenset[str]
    started: int | None
    now: int
    properties: list[PropertyMonitor]
    until_next: dict[str, list[tuple[list[Any], Fraction]]]
    complete_before: int
    reaches: dict[str, dict[str, int]]
    by_topic: dict[str, list[tuple[ir.Variable, Any]]]
    readers: Readers
    nodes: list[Node]
    state_of: dict[str, str]

    def _begin(self, time: int) -> None: ...

    # ---- input lost, late or damaged: the verdicts that read it are unknown ----

    def _late_input(self, time: int, topic: str) -> None:
        """A message of `topic` at `time` came after the monitor had passed its time:
        the input from `time` to the newest the monitor had is unknown (and on,
        until the topic publishes again, if it has not since)."""
        superseded = self.last_on.get(topic, -_FOREVER) > time
        noticed = max(self.now, self.complete_before)
        self._unknown_input(topic, time, noticed if superseded else None)

    def _unknown_input(self, topic: str, first: int, last: int | None) -> None:
        """What `topic` said from `first` to `last` (None: until it publishes
        again) is not known (a message late, lost, damaged or stamped ahead):
        every property reading the topic is unknown where its verdict reads that
        stretch, and what was given out there is revised."""
        if self.started is None:
            self._begin(first)
        assert self.started is not None
        reach = self._reach(topic)
        for monitor in self.properties:
            name = monitor.prop.name
            if name not in reach:
                continue
            # A window's point is stamped up to an interval before its input and
            # holds until the next: the stretch widens by the lead on both sides.
            lead = seconds(reach[name] + (monitor.period or 0))
            low = max(seconds(first) - lead - monitor.future, seconds(self.started))
            # With no bound back, every later verdict reads the gap: unknown for
            # the rest of the run (docs/runtime.md, "Lost, damaged and stamped-ahead input").
            after = None if monitor.past is None else lead + monitor.past
            high = None if last is None or after is None else seconds(last) + after
            interval = self.segments.unknown(name, low, high)
            if last is None and after is not None:
                self.until_next.setdefault(topic, []).append((interval, after))

    def _reach(self, topic: str) -> dict[str, int]:
        """The properties that read `topic`, with their leads, found once a topic (a
        flood of late messages walks the dataflow once, not per message)."""
        found = self.reaches.get(topic)
        if found is None:
            names = [v.name for v, read in self.by_topic.get(topic, ()) if read is not None]
            found = reaching(self.nodes, names, self.spec.properties, self.state_of)
            self.reaches[topic] = found
        return found

    def damaged(self, time: int, topic: str, reason: str) -> None:
        """A message that could not be decoded, received at `time`: what the topic
        says from then until its next message is unknown."""
        text = f"{topic}: a message cannot be decoded: {reason}"
        self._input_lost(time, topic, f"damaged messages: {topic}", 1, text)
        self._unknown_from(topic, time)

    def lost(self, time: int, topic: str, count: int) -> None:
        """Messages the transport lost (a host that sees gaps in the publishers'
        sequence numbers reports them before the message after the gap, at `time`):
        what the topic said since its last message is unknown."""
        text = (
            f"{topic}: {counted(count, 'message')} lost before the monitor could read "
            f"{'it' if count == 1 else 'them'} "
            "(a deeper `depth` in the topic's qos block keeps more waiting; a message "
            "that does not decode as the topic's type is lost too)"
        )
        self._input_lost(time, topic, f"lost messages: {topic}", count, text)
        self._unknown_from(topic, self.last_on.get(topic, time), since_last=True)

    def found_again(self, time: int, topic: str) -> None:
        """A message counted lost came after all (out of order): no longer lost,
        and counted as out of order; the stretch stays unknown."""
        self.counters[f"lost messages: {topic}"] -= 1
        if not self.counters[f"lost messages: {topic}"]:
            del self.counters[f"lost messages: {topic}"]
        text = f"{topic}: a message came after a later one (counted lost until it came)"
        self._input_lost(time, topic, f"messages out of order: {topic}", 1, text)

    def ahead(self, time: int, topic: str, stamp: int) -> None:
        """A message received at `time` stamped much later: dropped (its stamp would
        make every later message late), and unknown as a damaged one."""
        ahead = exact_text(seconds(stamp - time))
        text = (
            f"{topic}: a message stamped {ahead} s ahead of its receipt: dropped (a "
            f"stamp more than {exact_text(seconds(STAMP_AHEAD))} s ahead is not believed)"
        )
        self._input_lost(time, topic, f"messages stamped ahead dropped: {topic}", 1, text)
        self._unknown_from(topic, time)

    def over_rate(self, time: int, topic: str, limit: str) -> None:
        """A message past the topic's declared `max_rate` (received at `time`): it
        is read as any other; the count says the topic is flooded."""
        text = (
            f"{topic}: more messages than its max_rate ({limit}): each one past it is "
            "counted, and still read"
        )
        self._input_lost(time, topic, f"messages over max_rate: {topic}", 1, text)

    def _unknown_from(self, topic: str, time: int, since_last: bool = False) -> None:
        """The topic unknown from `time` (a receipt time), or from its last message
        (`since_last`, or a `time = header` topic: its times are stamps, another
        clock than receipt), until its next message. Before any message of a stamped
        topic there is nothing to leave unknown: its run starts with its first."""
        first: int | None = time
        if since_last or topic in self.stamped:
            first = self.last_on.get(topic, time if topic not in self.stamped else None)
        if first is None:
            if self.started is None:
                return
            first = self.now
        self._unknown_input(topic, first, None)

    def unreadable(self, time: int, listed: int, read: int) -> None:
        """The recording lists `listed` messages on the topics read, and gave `read`."""
        counter, text = unread(listed, read)
        self._input_lost(time, "", counter, abs(listed - read), text)

    def note(self, time: int, text: str) -> None:
        """Something about the input as a whole (a diagnostic record)."""
        self._note(time, text, "")

    def skip(self, time: int, topic: str, problems: dict[str, str]) -> None:
        """Variables of `topic` its input cannot give as the spec reads them (a live
        publisher's definition lacks the field, or holds another kind): from `time`
        on, not read, each warned of once at its declaration, as the replay skips
        them (rmvdsl.host.definitions; `problems`: name -> the warning)."""
        newly = self.readers.skip(topic, problems)
        if not newly:
            return
        self.reaches.pop(topic, None)
        for variable in newly:
            self._note(time, problems[variable.name], topic, variable.origin)

    def _field_error(self, time: int, topic: str, variable: ir.Variable, reason: str) -> None:
        text = f"{topic}: `{variable.name}` cannot be read: {reason}"
        counter = f"messages not matching the spec: {variable.name}"
        self._input_lost(time, topic, counter, 1, text, variable.origin)

    def _input_lost(
        self, time: int, topic: str, counter: str, count: int, text: str, origin: str = ""
    ) -> None:
        """Input the runtime could not use, or that breaks what the spec declares:
        always counted, reported once per counter (a topic's, or a variable's)."""
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

    def records(self) -> list[Record]:
        """The records produced since the last call, in the order they were decided."""
        out, self.out = self.out, []
        return out

    def _act(self, action: ir.Action, context: ActionContext) -> None:
        self.host.act(action, context)
        if isinstance(self.host, RecordingHost):  # its records go out in order
            self.out.extend(self.host.records)
            self.host.records.clear()

    def _alert(self, alert: ir.Alert, record: Record) -> None:
        self.out.append(record)
        self.counters[f"alerts: {alert.name}"] += 1
        for action in alert.actions:
            text = action_text(action, alert.message)
            level = action_level(action, _LOG_LEVEL[record["level"]])
            context = ActionContext("alert", alert.name, level, text, record)
            self._act(action, context)

    def _verdicts(self, monitor: PropertyMonitor) -> None:
        self.segments.add(monitor.prop, monitor.verdicts())

    @property
    def pending_segments(self) -> dict[str, list[Any]]:
        """Each property's open verdict segment (a live node's current verdict)."""
        return self.segments.pending

    def _write(self, record: Record) -> None:
        self.out.append(record)

    def _violated(self, prop: ir.Property, segment: list[Any]) -> None:
        self.counters[f"violations: {prop.name}"] += 1
        record = {"kind": "violation", "property": prop.name, "from": segment[0]}
        for action in prop.actions:
            text = action_text(action, f"{prop.name} violated")
            self._act(
                action,
                ActionContext("property", prop.name, action_level(action, "error"), text, record),
            )
