"""Lowering a checked model, part by part: the spec, its database, topics, message
types, variables and events (what it does about them: reactions.py)."""

from __future__ import annotations

from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path
from typing import Any

from rmvdsl.check.lowering import NotLowered, lower_expr, value_type
from rmvdsl.check.model import Model
from rmvdsl.check.msgdefs import FieldType, canonical
from rmvdsl.check.msgtypes import TypeRegistry
from rmvdsl.check.types import TypeInfo
from rmvdsl.grammar import ast
from rmvdsl.ir.conversions import LowerError, credential, primitive, reads, setting_value
from rmvdsl.ir.reactions import Reactions
from rmvdsl.lang import builtins
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.values import literal

# ROS 1 time fields as a decoded message names them (rosbags and rclpy alike).
_ROS1_TIME_READS = {"secs": "sec", "nsecs": "nanosec"}


class Lowering(Reactions):
    """A checked model, lowered part by part."""

    def __init__(self, model: Model, types: TypeInfo) -> None:
        self.model = model
        self.types = types
        self.registry: TypeRegistry = types.registry

    # ---- the whole spec ----

    def _file_name(self) -> str:
        specs = self.model.specs
        return Path(specs[0].path).stem if specs and specs[0].path != "-" else ""

    def spec(self) -> ir.Spec:
        model = self.model
        system = model.system
        topics = tuple(self.topic(t) for t in model.topics.values())
        return ir.Spec(
            format=ir.FORMAT,
            version=ir.VERSION,
            system=ir.System(
                # Without a `system` line, the spec is named after its file.
                system.name.name if system else self._file_name(),
                system.title.value if system and system.title else "",
                system.doc if system else "",
            ),
            time_unit=model.time_unit,
            ros=ir.Ros(self.registry.distro, self.registry.ros_version),
            database=self.database(model.database) if model.database else None,
            messages=self.messages(t.message_type for t in topics),
            topics=topics,
            variables=tuple(self.variable(v) for v in model.variables.values()),
            events=tuple(self.event(model.events[name]) for name in self.event_order()),
            transducers=tuple(self.transducer(t) for t in model.transducers.values()),
            properties=tuple(self.property(p) for p in model.properties.values()),
            alerts=tuple(self.alert(a) for a in model.alerts.values()),
            whitelists=tuple(self.whitelist(w) for w in model.whitelists),
            nodes=tuple(self.node_rule(n) for n in model.nodes),
            intrusion=self.intrusion(model.intrusion),
        )

    def origin(self, node: ast.Node) -> str:
        source = self.model.sources.get(node.span.path)
        if source is None:
            return node.span.path
        position = source.position(node.span.start)
        return f"{node.span.path}:{position.line}:{position.column}"

    # ---- settings ----

    def settings(self, block: str, given: Iterable[ast.Setting]) -> dict[str, Any]:
        """Every setting of the block: the spec's value, converted, or the default."""
        values = {s.key.name: setting_value(s.value) for s in given}
        out = {}
        for key, spec in builtins.block(block).settings.items():
            out[key] = values.get(key, spec.default)
        return out

    # ---- database ----

    def database(self, decl: ast.DatabaseDecl) -> ir.Database:
        values = self.settings("database", decl.settings)
        retentions = tuple(self.retention(r) for r in decl.retentions)
        default = next((r.name for r in retentions if r.default), "autogen")
        scheme = "https" if values["ssl"] else "http"
        url = values["url"]
        if url == builtins.DERIVED:
            url = f"{scheme}://{values['host']}:{values['port']}"
        return ir.Database(
            name=values["name"],
            url=url,
            host=values["host"],
            port=values["port"],
            precision=values["precision"],
            username=credential(values["username"]),
            password=credential(values["password"]),
            token=credential(values["token"]),
            ssl=values["ssl"],
            timeout=values["timeout"],
            batch_size=values["batch_size"],
            flush_interval=values["flush_interval"],
            default_retention=default,
            retentions=retentions,
            downsamples=tuple(self.downsample(d, default) for d in decl.downsamples),
            origin=self.origin(decl),
        )

    def retention(self, decl: ast.RetentionDecl) -> ir.Retention:
        values = self.settings("retention", decl.settings)
        duration = values["duration"]
        return ir.Retention(
            name=decl.name.name,
            duration=None if duration == "inf" else duration,
            replication=values["replication"],
            shard_duration=values["shard_duration"],
            default=values["default"],
            origin=self.origin(decl.name),
        )

    def downsample(self, decl: ast.DownsampleDecl, default: str) -> ir.Downsample:
        values = self.settings("downsample", decl.settings)
        lookback = values["for"]
        measurements = values["measurements"]
        return ir.Downsample(
            name=decl.name.name,
            source=default if values["from"] == builtins.DERIVED else values["from"],
            into=values["into"],
            every=values["every"],
            lookback=values["every"] if lookback == builtins.DERIVED else lookback,
            aggregate=values["aggregate"],
            measurements=None if measurements == builtins.DERIVED else tuple(measurements),
            origin=self.origin(decl.name),
        )

    # ---- topics and messages ----

    def topic(self, decl: ast.TopicDecl) -> ir.Topic:
        qos = self.settings("qos", decl.qos)
        time_source = qos.pop("time")
        max_rate = qos.pop("max_rate")
        return ir.Topic(
            name=decl.name.name,
            ros_name=decl.path.value,
            message_type=canonical(decl.msg_type.text),
            qos=ir.Qos(**qos),
            time_source=time_source,
            origin=self.origin(decl.name),
            doc=decl.doc,
            max_rate=max_rate,
        )

    def messages(self, roots: Iterable[str]) -> tuple[ir.Message, ...]:
        """Every message type the topics carry, nested ones included, by name."""
        found: dict[str, ir.Message] = {}
        pending = list(roots)
        while pending:
            name = pending.pop()
            definition = self.registry.get(name)
            if name in found or definition is None:
                continue
            fields = tuple(ir.MessageField(f, t.text()) for f, t in definition.fields.items())
            constants = tuple((c, kind, value) for c, (kind, value) in definition.constants.items())
            found[name] = ir.Message(name, fields, constants)
            bases = (t.base for t in definition.fields.values())
            pending += [canonical(base) for base in bases if not primitive(base)]
        return tuple(found[name] for name in sorted(found))

    # ---- variables ----

    def variable(self, decl: ast.VarDecl) -> ir.Variable:
        name = decl.name.name
        field_types = self.types.paths[name]
        steps: list[ir.Step] = []
        for segment, field_type in zip(decl.source.segments, field_types, strict=True):
            steps.append(self.field_step(segment.field_name.name, field_type))
            if segment.index == "*":
                steps.append(ir.EachStep())
            elif segment.index is not None:
                steps.append(ir.IndexStep(int(segment.index)))
        return ir.Variable(
            name=name,
            topic=decl.source.topic.name,
            path=tuple(steps),
            aggregate=decl.aggregate.name if decl.aggregate else None,
            type=value_type(self.types.variables[name]),
            origin=self.origin(decl.name),
            doc=decl.doc,
        )

    def field_step(self, name: str, field_type: FieldType) -> ir.FieldStep:
        read = name
        if self.registry.ros_version == 1 and name in _ROS1_TIME_READS:
            read = _ROS1_TIME_READS[name]
        return ir.FieldStep(name, read, field_type.text())

    # ---- expressions ----

    def expr(self, node: ast.Node) -> ir.Expr:
        try:
            return lower_expr(self.model, self.types, node)
        except NotLowered as error:
            raise LowerError(str(error)) from None

    # ---- events ----

    def event_order(self) -> list[str]:
        """Events after those they read, otherwise in declaration order (a depth-first
        walk by a loop: a chain of events can be long; the checker refused cycles)."""
        events = self.model.events
        order: dict[str, None] = {}
        for root in events:
            stack = [(root, False)]
            while stack:
                name, expanded = stack.pop()
                if name in order:
                    continue
                if expanded:
                    order[name] = None
                    continue
                stack.append((name, True))
                found = sorted(n for n in reads(events[name]) if n in events)
                stack.extend((n, False) for n in reversed(found) if n not in order)
        return list(order)

    def event(self, decl: ast.EventDecl) -> ir.Event:
        clauses = {c.kind: c.value for c in decl.clauses}
        group = clauses.get("group")
        window: ir.Window | None = None
        tags: tuple[str, ...] = ()
        if isinstance(group, ast.GroupBy):
            tags = tuple(t.value if isinstance(t, ast.StringLit) else t.name for t in group.tags)
            interval = self.seconds(group.interval)
            if interval is not None:
                window = ir.Window(interval, self.seconds(group.offset) or Fraction(0))
        resample = clauses.get("resample")
        every = lookback = None
        if isinstance(resample, ast.Resample):
            every, lookback = self.seconds(resample.every), self.seconds(resample.for_)
        if window is not None:  # InfluxDB's continuous querier's defaults, filled in
            every, lookback = ir.resampling(window.interval, every, lookback)
        elif every is not None:
            lookback = lookback or every
        where = clauses.get("where")
        limit = clauses.get("limit")
        order = clauses.get("order")
        return ir.Event(
            name=decl.name.name,
            kind="boolean" if decl.boolean else "value",
            expr=self.expr(decl.expr),
            type=value_type(self.types.events[decl.name.name]),
            reads=tuple(sorted(reads(decl))),
            where=self.expr(where) if where is not None else None,
            window=window,
            tags=tags,
            fill=self.fill(clauses.get("fill")),
            order=order.ident.name.lower() if isinstance(order, ast.NameValue) else "asc",
            limit=int(limit.value) if isinstance(limit, ast.NumberLit) else None,
            range=self.seconds(clauses.get("range")),
            resample_every=every,
            resample_for=lookback,
            origin=self.origin(decl.name),
            doc=decl.doc,
        )

    def seconds(self, node: ast.Node | None) -> Fraction | None:
        if not isinstance(node, ast.TimeLit):
            return None
        return node.time.seconds(self.model.time_unit)

    def fill(self, node: ast.Node | None) -> ir.Fill:
        if isinstance(node, ast.NameValue):
            return ir.Fill(node.ident.name)
        if isinstance(node, ast.NumberLit):
            kind = "int" if isinstance(literal(node.text), int) else "float"  # InfluxQL's rule
            return ir.Fill("number", ir.Number(node.text, node.value, ir.ValueType(kind)))
        return ir.Fill("null")  # InfluxDB's default

    # ---- transducers ----
