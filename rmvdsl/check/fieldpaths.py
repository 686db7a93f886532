"""Field paths (stage 3): each variable's path through real ROS message
definitions, segment by segment, to the value it reads."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rmvdsl.check.model import Model
from rmvdsl.check.msgdefs import FieldType, MessageDef, canonical
from rmvdsl.check.rosnames import message_type_problem
from rmvdsl.check.typeinfo import TypeInfo
from rmvdsl.check.vtypes import BOOL, FLOAT, INT, UNKNOWN, VType, from_ros
from rmvdsl.grammar import ast
from rmvdsl.lang.diagnostics import Diagnostic, did_you_mean, error
from rmvdsl.lang.source import Span


class FieldPaths:
    """The type stage's resolution of topics and variables (a part of TypeChecker)."""

    model: Model
    info: TypeInfo
    diagnostics: list[Diagnostic]

    def report(self, diagnostic: Diagnostic) -> None:
        self.diagnostics.append(diagnostic)

    # TypeChecker's: remembers a lookup for an incremental check.
    noted: Callable[[str, str, Any], None]

    def message(self, base: str) -> MessageDef | None:
        definition = self.info.registry.get(base)
        self.noted("message", base, definition)
        return definition

    def resolve_topic(self, topic: ast.TopicDecl) -> MessageDef | None:
        registry = self.info.registry
        definition = registry.get(topic.msg_type.text)
        if definition is not None:
            self.check_time_source(topic, definition)
            return definition
        if message_type_problem([p.name for p in topic.msg_type.parts]):
            return None  # not a type name at all: the names stage said so
        if canonical(topic.msg_type.text) in registry.broken:
            return None  # its .msg file has errors, reported there
        suggestion = registry.closest_type(topic.msg_type.text)
        package = topic.msg_type.parts[0].name
        known_package = registry.has_package(package)
        self.report(
            error(
                "RMV300",
                f"unknown message type `{topic.msg_type.text}`",
                topic.msg_type.span,
                label=(
                    f"no such type in package `{package}`"
                    if known_package
                    else f"no definitions of package `{package}` for ROS {registry.distro}"
                ),
                help=(f"did you mean `{suggestion}`?" if suggestion else None)
                or 'add its .msg folder with `messages "path"` or `rmv check --messages DIR`',
            )
        )
        return None

    def check_time_source(self, topic: ast.TopicDecl, definition: MessageDef) -> None:
        """`time = header` needs a `header` that is a std_msgs/Header."""
        value = topic.time_setting
        if value is None or value.ident.name != "header":
            return
        header = definition.fields.get("header")
        if header is None or header.array or canonical(header.base) != "std_msgs/msg/Header":
            self.report(
                error(
                    "RMV322",
                    f"`{definition.name}` has no header stamp to take the time from",
                    value.span,
                    label="its messages have no `header` field of type std_msgs/Header",
                    help="use `time = receipt` (the time a message arrives)",
                )
            )

    def type_variable(self, variable: ast.VarDecl) -> VType:
        topic = self.info.topics.get(variable.source.topic.name)
        self.noted("topic", variable.source.topic.name, topic)
        if topic is None:
            return UNKNOWN
        aggregates = variable.aggregate is not None and variable.aggregate.name != "number"
        if aggregates and not any(s.index == "*" for s in variable.source.segments):
            return UNKNOWN  # an aggregate without `[*]`: the names stage said so
        steps: list[FieldType] = []
        resolved = self.walk_path(topic, variable.source, steps)
        self.info.paths[variable.name.name] = tuple(steps)
        if resolved is None:
            return UNKNOWN
        field_type, wildcard, last = resolved
        if variable.aggregate is not None:
            return self.aggregate(variable, field_type, wildcard)
        if wildcard or field_type.array:
            self.report(
                error(
                    "RMV320",
                    f"`{variable.name.name}` is an array, not a value",
                    last.span,
                    label=f"{field_type.text() if field_type.array else field_type.base + '[*]'}",
                    help=f"aggregate it: `var {variable.name.name} = max("
                    f"{variable.source.topic.name}.{variable.source.text})`, "
                    "or pick one element with `[0]`",
                )
            )
            return UNKNOWN
        return self.scalar_of(variable, field_type, last)

    def scalar_of(self, variable: ast.VarDecl, field_type: FieldType, last: ast.Node) -> VType:
        value = from_ros(field_type.base)
        if value is UNKNOWN:
            message = self.info.registry.get(field_type.base)
            fields = ", ".join(list(message.fields)[:6]) if message else ""
            self.report(
                error(
                    "RMV303",
                    f"`{variable.name.name}` is a whole message ({field_type.base}), not a value",
                    last.span,
                    label="pick one of its fields",
                    help=f"its fields: {fields}" if fields else None,
                )
            )
        return value

    def walk_path(
        self, message: MessageDef, ref: ast.FieldRef, steps: list[FieldType] | None = None
    ) -> tuple[FieldType, bool, ast.Node] | None:
        """The type at the end of the path, whether it crossed a `[*]`, and its last
        node; `steps` receives each segment's field type."""
        current = FieldType(message.name)
        wildcard = False
        previous: ast.Node = ref.topic
        for segment in ref.segments:
            if current.array:
                self.report_unindexed_array(previous, current)
                return None
            fields = self.fields_of(current.base)
            if fields is None:
                self.report(
                    error(
                        "RMV301",
                        f"`{previous_name(previous)}` is a {current.base}, which has no fields",
                        segment.field_name.span,
                        label="no field here",
                        help=f"end the path at `{previous_name(previous)}`",
                    )
                )
                return None
            found = fields.get(segment.field_name.name)
            if found is None:
                found = self.constant(current.base, segment)
                if found is None:
                    self.report_missing_field(current.base, fields, segment)
                    return None
            current = found
            if steps is not None:
                steps.append(found)
            if segment.index is not None:
                if not current.array:
                    self.report(
                        error(
                            "RMV302",
                            f"`{segment.field_name.name}` is not an array ({current.text()})",
                            segment.span,
                            label="cannot be indexed",
                            help=f"write `{segment.field_name.name}` without `[{segment.index}]`",
                        )
                    )
                    return None
                if self.out_of_range(segment, current):
                    return None
                wildcard = wildcard or segment.index == "*"
                current = current.element()
            previous = segment
        return current, wildcard, previous

    def out_of_range(self, segment: ast.Segment, array: FieldType) -> bool:
        size = array.size
        if not isinstance(segment.index, int) or size is None or array.bounded:
            return False
        if segment.index < size:
            return False
        self.report(
            error(
                "RMV302",
                f"index {segment.index} is out of range for `{segment.field_name.name}` "
                f"({array.text()})",
                segment.span,
                label=f"indices are 0..{size - 1}",
            )
        )
        return True

    def fields_of(self, base: str) -> dict[str, FieldType] | None:
        if base in ("time", "duration") and self.info.registry.ros_version == 1:
            return self.info.registry.time_fields(base)
        definition = self.message(base)
        return definition.fields if definition is not None else None

    def constant(self, base: str, segment: ast.Segment) -> FieldType | None:
        definition = self.message(base)
        if definition is None or segment.field_name.name not in definition.constants:
            return None
        return FieldType(definition.constants[segment.field_name.name][0])

    def report_missing_field(
        self, base: str, fields: dict[str, FieldType], segment: ast.Segment
    ) -> None:
        name = segment.field_name.name
        definition = self.info.registry.get(base)
        candidates = [*fields, *(definition.constants if definition else ())]
        hint = did_you_mean(name, candidates)
        if (
            hint is None
            and self.info.registry.ros_version == 2
            and name in ("secs", "nsecs", "seq")
        ):
            hint = "ROS 2 time has `sec` and `nanosec`, and its Header has no `seq`"
        elif hint is None and self.info.registry.ros_version == 1 and name in ("sec", "nanosec"):
            hint = "ROS 1 time has `secs` and `nsecs`"
        self.report(
            error(
                "RMV301",
                f"{base} has no field `{name}`",
                segment.field_name.span,
                label="no such field",
                help=hint or "its fields: " + ", ".join(list(fields)[:8]),
            )
        )

    def report_unindexed_array(self, previous: ast.Node, current: FieldType) -> None:
        name = previous_name(previous)
        self.report(
            error(
                "RMV302",
                f"`{name}` is an array ({current.text()}): say which element",
                previous.span,
                label="an array here",
                help=f"write `{name}[0]` for one element, or `{name}[*]` with an aggregate",
            )
        )

    def aggregate(self, variable: ast.VarDecl, element: FieldType, wildcard: bool) -> VType:
        assert variable.aggregate is not None
        name = variable.aggregate.name
        value = from_ros(element.base)
        if name == "number":
            if value.kind != "bool" or wildcard:
                self.report(
                    error(
                        "RMV313",
                        f"`number(...)` turns a bool into 0 or 1, but this is {value.describe()}",
                        variable.source.span,
                        label="not a single bool",
                    )
                )
            return VType("int", "bool as number")
        if not wildcard:
            return UNKNOWN  # reported by the names stage (RMV218)
        if name == "count":
            return INT
        if name in ("any", "all"):
            if value.kind != "bool":
                self.report(self.argument_error(name, "bools", value, variable.source.span))
            return BOOL
        if not value.numeric:
            self.report(self.argument_error(name, "numbers", value, variable.source.span))
            return UNKNOWN
        return FLOAT if name == "mean" else value

    @staticmethod
    def argument_error(function: str, wanted: str, got: VType, span: Span) -> Diagnostic:
        return error(
            "RMV313",
            f"`{function}` needs {wanted}, but its argument is {got.describe()}",
            span,
            label=f"{got.describe()}",
            help="compare a bool (`X = true`) or convert it with `number(...)` in the variable"
            if got.kind == "bool"
            else None,
        )


def previous_name(node: ast.Node) -> str:
    if isinstance(node, ast.Segment):
        return node.field_name.name
    if isinstance(node, ast.Ident):
        return node.name
    return "?"
