"""Variables as InfluxDB points (line protocol), the storage of the kapacitor
target (docs/kapacitor.md, "Schema"). Standard library only: the collector node
embeds it.

One message is one point, as it is one row for the runtime's continuous queries:
the measurement is the spec's system name, the tag `topic` is the topic's ROS name
(so two topics' messages at one instant stay two points), and each variable of the
topic is a field named after it. A variable with no sample in a message is left out
of that point; a NaN or an infinity cannot be stored (InfluxDB refuses the whole
point), so that field is left out and counted.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Iterable
from typing import Any

from rmvdsl.runtime import fields
from rmvdsl.runtime import spec as ir

TOPIC_TAG = "topic"


def measurement_name(spec: ir.Spec) -> str:
    """The one measurement that holds a spec's variables and value events."""
    return spec.system.name


def states_measurement(spec: ir.Spec) -> str:
    """The measurement of the transducers' states: a point per state entered."""
    return f"{spec.system.name}_states"


def state_point(spec: ir.Spec, transducer: str, state: str, time: int) -> str:
    """The line of a state entered at `time` (ns): tagged with its transducer."""
    measurement = measurement_text(states_measurement(spec))
    return f"{measurement},transducer={key_text(transducer)} state={field_value(state)} {time}"


def _escape(text: str, special: str) -> str:
    """Line protocol escapes only its separators in names; a backslash is read as
    an escape before them and as itself elsewhere, so a name holding one (or a
    newline, which ends the line) has no exact spelling: refused, never mangled.
    The names written are the spec's identifiers and ROS names, which hold neither."""
    if "\\" in text or "\n" in text:
        raise ValueError(f"{text!r} cannot be a line protocol name")
    for char in special:
        text = text.replace(char, "\\" + char)
    return text


def measurement_text(name: str) -> str:
    """A measurement name in line protocol (commas and spaces escaped)."""
    return _escape(name, ", ")


def key_text(name: str) -> str:
    """A tag key, tag value or field key in line protocol (commas, equals signs
    and spaces escaped)."""
    return _escape(name, ",= ")


def field_value(value: Any) -> str | None:
    """A field value in line protocol, or None when InfluxDB cannot store it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return f"{value}i"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else None
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return None


class PointWriter:
    """Reads a topic's variables from a message and writes its point."""

    def __init__(self, spec: ir.Spec) -> None:
        self.measurement = measurement_text(measurement_name(spec))
        self.readers: dict[str, list[tuple[str, Callable[[Any], Any]]]] = {}
        ros_names = {t.name: t.ros_name for t in spec.topics}
        for variable in spec.variables:
            topic = ros_names[variable.topic]
            self.readers.setdefault(topic, []).append((variable.name, fields.reader(variable)))
        self.stamped = fields.stamped_topics(spec.topics)
        self.dropped: Counter[str] = Counter()

    def skip(self, topic: str, names: Iterable[str]) -> None:
        """Variables of `topic` no longer read (Runtime.skip)."""
        left_out = set(names)
        if topic in self.readers:
            self.readers[topic] = [r for r in self.readers[topic] if r[0] not in left_out]

    def point(self, time: int, topic: str, message: Any) -> tuple[int, str] | None:
        """The point of one message received at `time` (ns): its time (the header's
        stamp for a `time = header` topic) and its line, or None when no variable
        of the topic has a value in it (counted in `dropped`, by cause)."""
        readers = self.readers.get(topic)
        if readers is None:
            return None
        if topic in self.stamped:
            try:
                time = fields.stamp(message)
            except fields.FieldError:
                self.dropped[f"damaged messages: {topic}"] += 1
                return None
        values = []
        for name, read in readers:
            try:
                value = read(message)
            except fields.FieldError:
                self.dropped[f"messages not matching the spec: {name}"] += 1
                continue
            if value is fields.MISSING:
                continue
            if not isinstance(value, (bool, int, float, str)):
                value = float(value)  # a time or duration: exact seconds
            text = field_value(value)
            if text is None:
                self.dropped[f"values InfluxDB cannot store: {name}"] += 1
                continue
            values.append(f"{key_text(name)}={text}")
        if not values:
            self.dropped[f"messages with no value to store: {topic}"] += 1
            return None
        tags = f"{TOPIC_TAG}={key_text(topic)}"
        return time, f"{self.measurement},{tags} {','.join(values)} {time}"
