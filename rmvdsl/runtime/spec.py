"""The resolved spec: one immutable, fully typed, target-neutral value that the
runtime, every target and the editor read (docs/ir.md). Standard library only:
generated nodes embed it and load the spec's JSON with it.

`rmvdsl.ir.lower` builds it from a checked spec; `dump` and `load` convert it to
and from its versioned JSON form, exactly (JSON -> value -> JSON is identical).
Every default is filled in (from rmvdsl.lang.builtins); times are seconds, exact.
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, ClassVar

from rmvdsl.runtime import formulas
from rmvdsl.runtime.jsonform import Codec
from rmvdsl.runtime.spec_terms import Action as Action
from rmvdsl.runtime.spec_terms import Binary as Binary
from rmvdsl.runtime.spec_terms import Boolean as Boolean
from rmvdsl.runtime.spec_terms import Call as Call
from rmvdsl.runtime.spec_terms import Credential as Credential
from rmvdsl.runtime.spec_terms import Exec as Exec
from rmvdsl.runtime.spec_terms import Expr as Expr
from rmvdsl.runtime.spec_terms import Log as Log
from rmvdsl.runtime.spec_terms import Number as Number
from rmvdsl.runtime.spec_terms import Pattern as Pattern
from rmvdsl.runtime.spec_terms import Post as Post
from rmvdsl.runtime.spec_terms import Publish as Publish
from rmvdsl.runtime.spec_terms import Ref as Ref
from rmvdsl.runtime.spec_terms import String as String
from rmvdsl.runtime.spec_terms import Tcp as Tcp
from rmvdsl.runtime.spec_terms import Time as Time
from rmvdsl.runtime.spec_terms import Unary as Unary
from rmvdsl.runtime.spec_terms import ValueType as ValueType

FORMAT = "rmvdsl.ir"
VERSION = 1


class FormatError(ValueError):
    """A JSON text that is not a resolved spec of this version."""


# ---- header ----


@dataclass(frozen=True)
class System:
    name: str
    title: str
    doc: str


@dataclass(frozen=True)
class Ros:
    distro: str
    version: int  # 1 or 2


# ---- database ----


@dataclass(frozen=True)
class Retention:
    name: str
    duration: Fraction | None  # None: forever (`inf`)
    replication: int
    shard_duration: Fraction | None  # None: InfluxDB chooses
    default: bool
    origin: str


@dataclass(frozen=True)
class Downsample:
    name: str
    source: str  # the retention policy read
    into: str
    every: Fraction
    lookback: Fraction  # RESAMPLE ... FOR
    aggregate: str
    measurements: tuple[str, ...] | None  # None: every measurement
    origin: str


@dataclass(frozen=True)
class Database:
    name: str
    url: str
    host: str
    port: int
    precision: str
    username: Credential | None
    password: Credential | None
    token: Credential | None
    ssl: bool
    timeout: Fraction
    batch_size: int
    flush_interval: Fraction
    default_retention: str  # `autogen` when no policy is the default
    retentions: tuple[Retention, ...]
    downsamples: tuple[Downsample, ...]
    origin: str


# ---- messages and topics ----


@dataclass(frozen=True)
class MessageField:
    name: str
    type: str  # `float32`, `pkg/msg/Type`, arrays as `T[]`, `T[3]`, `T[<=3]`


@dataclass(frozen=True)
class Message:
    name: str  # pkg/msg/Type
    fields: tuple[MessageField, ...]
    constants: tuple[tuple[str, str, str], ...]  # (name, type, value)


@dataclass(frozen=True)
class Qos:
    depth: int
    history: str
    reliability: str
    durability: str
    deadline: Fraction | None
    lifespan: Fraction | None
    liveliness: str
    liveliness_lease: Fraction | None


@dataclass(frozen=True)
class Topic:
    name: str
    ros_name: str
    message_type: str  # pkg/msg/Type
    qos: Qos
    time_source: str  # receipt: the time the message arrived
    origin: str
    doc: str
    max_rate: Fraction | None = None  # Hz: more is counted (runtime/rates.py)


# ---- variables ----


@dataclass(frozen=True)
class FieldStep:
    TAG: ClassVar[str] = "field"
    name: str  # as the spec writes it
    read: str  # the field of the decoded message (ROS 1 `secs` is `sec` there)
    type: str  # the field's ROS type, `[]` for arrays


@dataclass(frozen=True)
class IndexStep:
    TAG: ClassVar[str] = "index"
    index: int


@dataclass(frozen=True)
class EachStep:
    TAG: ClassVar[str] = "each"


Step = FieldStep | IndexStep | EachStep


@dataclass(frozen=True)
class Variable:
    name: str
    topic: str
    path: tuple[Step, ...]
    aggregate: str | None  # an array aggregate over the `[*]`, or `number`
    type: ValueType
    origin: str
    doc: str


# ---- events ----


@dataclass(frozen=True)
class Window:
    """`group by time(interval, offset)`: windows aligned to the epoch plus offset."""

    interval: Fraction
    offset: Fraction


def published_topics(spec: Spec) -> tuple[str, ...]:
    """Every topic a `publish` action of the spec writes on, in declaration order:
    a live host makes their publishers at start-up (a publisher made at the first
    alert loses it to subscribers not yet matched)."""
    actions: list[Action] = [a for p in spec.properties for a in p.actions]
    actions += [a for alert in spec.alerts for a in alert.actions]
    actions += [a for w in spec.whitelists for a in w.actions]
    actions += [a for n in spec.nodes for a in n.actions]
    actions += spec.intrusion.actions
    return tuple(dict.fromkeys(a.topic for a in actions if isinstance(a, Publish)))


def resampling(
    interval: Fraction, every: Fraction | None, lookback: Fraction | None
) -> tuple[Fraction, Fraction]:
    """InfluxDB's continuous querier's defaults, the one place they are written: a
    query runs every `every` (default: the window) and each run reads `for` back
    (default: the longer of the window and `every`)."""
    every = every or interval
    return every, lookback or max(every, interval)


@dataclass(frozen=True)
class Fill:
    mode: str  # none | null | previous | linear | number
    value: Number | None = None  # for `number`


@dataclass(frozen=True)
class Event:
    name: str
    kind: str  # value | boolean
    expr: Expr
    type: ValueType
    reads: tuple[str, ...]  # the variables and events it uses
    where: Expr | None
    window: Window | None
    tags: tuple[str, ...]
    fill: Fill
    order: str
    limit: int | None
    range: Fraction | None  # `time >= now() - range`
    resample_every: Fraction | None  # how often the continuous query runs
    resample_for: Fraction | None  # how far back each run reads
    origin: str
    doc: str


# ---- transducers, properties, alerts ----


@dataclass(frozen=True)
class Transition:
    source: str
    dest: str
    input: str
    emit: str | None
    origin: str


@dataclass(frozen=True)
class Transducer:
    name: str
    states: tuple[str, ...]
    initial: str
    finals: tuple[str, ...]
    complete: bool
    transitions: tuple[Transition, ...]
    emits: tuple[str, ...]
    origin: str
    doc: str


@dataclass(frozen=True)
class Property:
    name: str
    text: str  # the formula as rmv fmt prints it
    formula: Any  # rmvdsl.runtime.formulas nodes, times in seconds
    propositions: tuple[str, ...]
    horizon_future: Fraction
    horizon_past: Fraction | None  # None: back to the trace's start (no bound)
    rate: Fraction | None  # Hz; None: every instant (exact segments)
    trigger: str  # `always`, or a state or boolean event
    window: Fraction
    lateness: Fraction
    actions: tuple[Action, ...]
    origin: str
    doc: str


@dataclass(frozen=True)
class AlertLevel:
    severity: str  # info | warn | crit
    condition: Expr
    reset: Expr | None


@dataclass(frozen=True)
class Alert:
    name: str
    id: str
    message: str
    details: str
    state_changes_only: bool
    no_recoveries: bool
    levels: tuple[AlertLevel, ...]
    reads: tuple[str, ...]
    actions: tuple[Action, ...]
    origin: str
    doc: str


# ---- intrusion detection ----


@dataclass(frozen=True)
class Whitelist:
    topic: Pattern  # a ROS topic name or pattern
    topic_name: str | None  # the spec's short name, when it names a declared topic
    publishers: tuple[Pattern, ...] | None  # None: no restriction
    subscribers: tuple[Pattern, ...] | None
    actions: tuple[Action, ...]
    origin: str
    doc: str


@dataclass(frozen=True)
class NodeRule:
    node: Pattern
    publishes: tuple[Pattern, ...] | None
    subscribes: tuple[Pattern, ...] | None
    actions: tuple[Action, ...]
    origin: str
    doc: str


@dataclass(frozen=True)
class Intrusion:
    poll: Fraction
    default: str  # allow | deny
    ignore_nodes: tuple[Pattern, ...]
    # `ros`: the topics ROS itself has every node use (builtins.INFRASTRUCTURE, by
    # the ROS version the monitor runs on) are never intrusions, unless a whitelist
    # names the topic; `none`: no exception.
    infrastructure: str
    actions: tuple[Action, ...]
    origin: str  # empty without an `intrusion` block


# ---- the spec ----


@dataclass(frozen=True)
class Spec:
    format: str
    version: int
    system: System
    time_unit: str | None
    ros: Ros
    database: Database | None
    messages: tuple[Message, ...]
    topics: tuple[Topic, ...]
    variables: tuple[Variable, ...]
    events: tuple[Event, ...]  # in dependency order: each after what it reads
    transducers: tuple[Transducer, ...]
    properties: tuple[Property, ...]
    alerts: tuple[Alert, ...]
    whitelists: tuple[Whitelist, ...]
    nodes: tuple[NodeRule, ...]
    intrusion: Intrusion


def pattern(text: str) -> Pattern:
    """A ROS name pattern and its anchored regular expression."""
    return Pattern(text, "^" + ".*".join(re.escape(part) for part in text.split("*")) + "$")


# ---- JSON ----

_TAGGED = {
    cls.TAG: cls
    for cls in (FieldStep, IndexStep, EachStep, Number, String, Boolean, Time, Ref, Unary,
                Binary, Call, Log, Publish, Post, Exec, Tcp)
}  # fmt: skip
# A property's formula travels as nested lists (rmvdsl.runtime.formulas).
_CODEC = Codec(
    _TAGGED, vars(sys.modules[__name__]),
    {(Property, "formula"): (formulas.to_lists, lambda v: formulas.from_lists(v, Fraction))},
)  # fmt: skip


def dump(spec: Spec, indent: int | None = 2) -> str:
    """The spec's JSON text: exact numbers (a decimal where one is exact, else the
    quotient as a string such as "1/3"), fields in declaration order."""
    return _CODEC.dump(spec, indent)


def load(text: str) -> Spec:
    """The spec of a JSON text written by `dump` (FormatError when it is not one)."""
    try:
        payload = json.loads(text, parse_float=str, parse_int=str)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise FormatError(f"not JSON: {exc}") from None
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise FormatError(f'not a resolved spec (no "format": "{FORMAT}")')
    if payload.get("version") != str(VERSION):
        raise FormatError(f"version {payload.get('version')} of the format; this reads {VERSION}")
    try:
        spec: Spec = _CODEC.decode(Spec, payload)
    except (TypeError, ValueError, KeyError, ZeroDivisionError) as exc:
        raise FormatError(f"malformed resolved spec: {exc}") from None
    return spec
