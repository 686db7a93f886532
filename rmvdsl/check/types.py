"""Types (stage 3): every variable against real ROS message definitions, then
events, alerts and properties, with time units and property horizons.

Value types are small: bool, int, float, string, time, duration. A numeric value
also carries its time exponent (`derivative(x, 1s)` is x per second: -1), so that a
rate of change compared with a value is reported; literals adapt to any unit.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from fractions import Fraction

from rmvdsl.check.model import Kind, Model
from rmvdsl.check.msgtypes import (
    DEFAULT_DISTRO,
    DISTROS,
    FLOATS,
    INTEGERS,
    FieldType,
    MessageDef,
    TypeRegistry,
    canonical,
    environment_folders,
)
from rmvdsl.check.rosnames import message_type_problem
from rmvdsl.diagnostics import Diagnostic, Label, did_you_mean, error
from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.runtime.values import literal
from rmvdsl.source import Span

NUMERIC = frozenset({"int", "float"})


@dataclass(frozen=True)
class VType:
    kind: str  # bool | int | float | string | time | duration | unknown
    ros: str = ""  # the ROS type it comes from, for messages and hover
    rate: int = 0  # time exponent: -1 for a derivative, +1 for an integral
    literal: bool = False  # a constant written in the spec: adapts to units

    @property
    def numeric(self) -> bool:
        return self.kind in NUMERIC

    @property
    def adapts(self) -> bool:
        """A bare number written in the spec: it takes the unit of what it meets."""
        return self.literal and self.kind in NUMERIC and self.rate == 0

    @property
    def exponent(self) -> int:
        """The power of seconds in its unit: 1 for a time, -1 for a rate, 0 for none."""
        return self.rate + (1 if self.kind == "duration" else 0)

    def describe(self) -> str:
        name = self.ros or self.kind
        if self.rate < 0:
            name += " per second" if self.rate == -1 else f" per second^{-self.rate}"
        elif self.rate > 0:
            name += " times seconds" if self.rate == 1 else f" times seconds^{self.rate}"
        return name


UNKNOWN = VType("unknown")
BOOL = VType("bool")
INT = VType("int")
FLOAT = VType("float")
STRING = VType("string")
DURATION = VType("duration")


def from_ros(base: str) -> VType:
    if base == "bool":
        return VType("bool", base)
    if base in INTEGERS:
        return VType("int", base)
    if base in FLOATS:
        return VType("float", base)
    if base in ("string", "wstring"):
        return VType("string", base)
    if base in ("time", "builtin_interfaces/msg/Time"):
        return VType("time", base)
    if base in ("duration", "builtin_interfaces/msg/Duration"):
        return VType("duration", base)
    return UNKNOWN


@dataclass
class Horizon:
    """How far a property looks into the future and the past, in seconds."""

    future: Fraction
    past: Fraction

    @property
    def total(self) -> Fraction:
        return self.future + self.past


@dataclass
class TypeInfo:
    registry: TypeRegistry
    topics: dict[str, MessageDef | None] = field(default_factory=dict)
    variables: dict[str, VType] = field(default_factory=dict)
    events: dict[str, VType] = field(default_factory=dict)
    horizons: dict[str, Horizon] = field(default_factory=dict)


@dataclass
class TypeConfig:
    """Where the ROS distribution and message folders come from (the command line
    wins over the spec, the spec over rmv.toml)."""

    ros: str | None = None
    messages: tuple[str, ...] = ()
    use_environment: bool = True


# Function signatures: (least, most arguments, what the first must be, result).
# `same` keeps the argument's type, `rate` changes its time exponent.
_ANY, _NUM = "any", "numeric"
FUNCTIONS: dict[str, tuple[int, int, str, str]] = {
    "count": (1, 1, _ANY, "int"),
    "distinct": (1, 1, _ANY, "same"),
    "mode": (1, 1, _ANY, "same"),
    "first": (1, 1, _ANY, "same"),
    "last": (1, 1, _ANY, "same"),
    "sample": (2, 2, _ANY, "same"),
    "integral": (1, 2, _NUM, "rate+1"),
    "mean": (1, 1, _NUM, "float"),
    "median": (1, 1, _NUM, "float"),
    "spread": (1, 1, _NUM, "same"),
    "stddev": (1, 1, _NUM, "float"),
    "sum": (1, 1, _NUM, "same"),
    "max": (1, 1, _NUM, "same"),
    "min": (1, 1, _NUM, "same"),
    "top": (2, 2, _NUM, "same"),
    "bottom": (2, 2, _NUM, "same"),
    "percentile": (2, 2, _NUM, "same"),
    "derivative": (1, 2, _NUM, "rate-1"),
    "non_negative_derivative": (1, 2, _NUM, "rate-1"),
    "difference": (1, 1, _NUM, "same"),
    "non_negative_difference": (1, 1, _NUM, "same"),
    "cumulative_sum": (1, 1, _NUM, "same"),
    "moving_average": (2, 2, _NUM, "float"),
    "elapsed": (1, 2, _ANY, "duration"),
    "histogram": (1, 3, _NUM, "float"),
    "abs": (1, 1, _NUM, "same"),
    "ceil": (1, 1, _NUM, "same"),
    "floor": (1, 1, _NUM, "same"),
    "round": (1, 1, _NUM, "same"),
    "pow": (2, 2, _NUM, "float"),
    "atan2": (2, 2, _NUM, "float"),
    "log": (2, 2, _NUM, "float"),
    **{name: (1, 1, _NUM, "float") for name in
       ("sqrt", "exp", "ln", "log2", "log10", "sin", "cos", "tan", "asin", "acos", "atan")},
}  # fmt: skip
# Second arguments that must be a time (the unit of a derivative) or a count.
_TIME_ARGUMENT = {"derivative", "non_negative_derivative", "integral", "elapsed"}
_COUNT_ARGUMENT = {"top", "bottom", "moving_average", "sample"}


class TypeChecker:
    def __init__(self, model: Model, config: TypeConfig, spec_folder: str) -> None:
        self.model = model
        self.config = config
        self.spec_folder = spec_folder
        self.diagnostics: list[Diagnostic] = []
        self.info = TypeInfo(TypeRegistry(self._distro()))
        self._event_stack: set[str] = set()

    def report(self, diagnostic: Diagnostic) -> None:
        self.diagnostics.append(diagnostic)

    # ---- configuration ----

    def _distro(self) -> str:
        if self.config.ros:
            return self.config.ros
        ros = self.model.ros
        if ros is not None:
            name = ros.distro.name
            if name in DISTROS:
                return name
            self.report(
                error(
                    "RMV305",
                    f"unknown ROS distribution `{name}`",
                    ros.distro.span,
                    label="not a distribution rmvdsl has message definitions for",
                    help=did_you_mean(name, DISTROS) or "known: " + ", ".join(DISTROS),
                )
            )
        return DEFAULT_DISTRO

    def load_messages(self) -> None:
        registry = self.info.registry
        for folder in self.config.messages:
            registry.add_folder(folder, None)
            if not os.path.isdir(folder):
                self.report(
                    error(
                        "RMV306",
                        f"message folder `{folder}` does not exist",
                        Span("<command line>", 0, 0),
                    )
                )
        for decl in self.model.messages:
            base = os.path.dirname(decl.span.path)
            registry.add_folder(
                os.path.normpath(os.path.join(base, decl.path.value)), decl.path.span
            )
        if self.config.use_environment:
            for folder in environment_folders():
                registry.add_folder(folder)
        self.diagnostics.extend(registry.diagnostics)
        for source in registry.sources:
            self.model.sources.add(source)

    # ---- driver ----

    def run(self) -> tuple[TypeInfo, list[Diagnostic]]:
        self.load_messages()
        for name, topic in self.model.topics.items():
            self.info.topics[name] = self.resolve_topic(topic)
        for name, variable in self.model.variables.items():
            self.info.variables[name] = self.type_variable(variable)
        for name in self.model.events:
            self.event_type(name)
        for alert in self.model.alerts.values():
            self.check_alert(alert)
        for prop in self.model.properties.values():
            self.check_property(prop)
        return self.info, self.diagnostics

    # ---- topics and variables ----

    def resolve_topic(self, topic: ast.TopicDecl) -> MessageDef | None:
        registry = self.info.registry
        definition = registry.get(topic.msg_type.text)
        if definition is not None:
            return definition
        if message_type_problem([p.name for p in topic.msg_type.parts]):
            return None  # not a type name at all: the names stage said so
        if canonical(topic.msg_type.text) in registry.broken:
            return None  # its .msg file has errors, reported there
        suggestion = registry.closest_type(topic.msg_type.text)
        package = topic.msg_type.parts[0].name
        known_package = any(n.startswith(package + "/") for n in registry.names())
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

    def type_variable(self, variable: ast.VarDecl) -> VType:
        topic = self.info.topics.get(variable.source.topic.name)
        if topic is None:
            return UNKNOWN
        aggregates = variable.aggregate is not None and variable.aggregate.name != "number"
        if aggregates and not any(s.index == "*" for s in variable.source.segments):
            return UNKNOWN  # an aggregate without `[*]`: the names stage said so
        resolved = self.walk_path(topic, variable.source)
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
        self, message: MessageDef, ref: ast.FieldRef
    ) -> tuple[FieldType, bool, ast.Node] | None:
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
        definition = self.info.registry.get(base)
        return definition.fields if definition is not None else None

    def constant(self, base: str, segment: ast.Segment) -> FieldType | None:
        definition = self.info.registry.get(base)
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

    # ---- expressions ----

    def event_type(self, name: str) -> VType:
        if name in self.info.events:
            return self.info.events[name]
        decl = self.model.events.get(name)
        if decl is None:
            return BOOL if name in self.model.emitted else UNKNOWN
        if name in self._event_stack:
            return UNKNOWN  # a cycle, reported by the names stage
        self._event_stack.add(name)
        value = self.expression(decl.expr)
        where = decl.clause("where")
        if where is not None:
            self.condition(where.value, "a `where` clause")
        if decl.boolean:
            self.condition(decl.expr, f"the condition of `{name}`", value)
            value = BOOL
        self._event_stack.discard(name)
        self.info.events[name] = value
        return value

    def condition(self, expr: ast.Node, what: str, value: VType | None = None) -> None:
        value = value or self.expression(expr)
        if value.kind not in ("bool", "unknown"):
            self.report(
                error(
                    "RMV312",
                    f"{what} must be true or false, but it is {value.describe()}",
                    expr.span,
                    label=f"{value.describe()}",
                    help="compare it, e.g. `... > 0`",
                )
            )

    def expression(self, expr: ast.Node) -> VType:
        match expr:
            case ast.NumberLit():
                kind = "int" if isinstance(literal(expr.text), int) else "float"
                return VType(kind, literal=True)
            case ast.TimeLit():
                return VType("duration", literal=True)
            case ast.RateLit():
                return VType("float", rate=-1, literal=True)
            case ast.StringLit():
                return VType("string", literal=True)
            case ast.BoolLit():
                return VType("bool", literal=True)
            case ast.NameRef():
                return self.name_type(expr.ident.name)
            case ast.UnaryOp():
                return self.unary(expr)
            case ast.BinOp():
                return self.binary(expr)
            case ast.Call():
                return self.call(expr)
        return UNKNOWN

    def name_type(self, name: str) -> VType:
        symbol = self.model.symbols.get(name)
        if symbol is None:
            return UNKNOWN
        if symbol.kind is Kind.VARIABLE:
            return self.info.variables.get(name, UNKNOWN)
        if symbol.kind in (Kind.VALUE_EVENT, Kind.BOOL_EVENT, Kind.EMITTED_EVENT):
            return self.event_type(name)
        return UNKNOWN

    def unary(self, expr: ast.UnaryOp) -> VType:
        operand = self.expression(expr.operand)
        if expr.op == "not":
            self.condition(expr.operand, "the operand of `not`", operand)
            return BOOL
        if operand.kind not in ("int", "float", "duration", "unknown"):
            self.report(self.operand_error("-", expr.operand, operand, "a number"))
            return UNKNOWN
        return operand

    def binary(self, expr: ast.BinOp) -> VType:
        left, right = self.expression(expr.left), self.expression(expr.right)
        op = expr.op
        if op in ("and", "or"):
            self.condition(expr.left, f"the left side of `{op}`", left)
            self.condition(expr.right, f"the right side of `{op}`", right)
            return BOOL
        if op in ("=", "!=", "<", "<=", ">", ">=", "=~", "!~"):
            self.comparison(expr, left, right)
            return BOOL
        if op in ("&", "|", "^"):
            for side, value in ((expr.left, left), (expr.right, right)):
                if value.kind not in ("int", "unknown"):
                    self.report(self.operand_error(op, side, value, "an integer"))
            return INT
        return self.arithmetic(expr, left, right)

    def arithmetic(self, expr: ast.BinOp, left: VType, right: VType) -> VType:
        op = expr.op
        bad = False
        for side, value in ((expr.left, left), (expr.right, right)):
            if value.kind not in ("int", "float", "duration", "unknown"):
                self.report(self.operand_error(op, side, value, "a number"))
                bad = True
        if bad or UNKNOWN in (left, right):
            return UNKNOWN
        if op in ("+", "-"):
            if _units_clash(left, right):
                self.report(self.unit_error(expr, left, right, f"`{op}` adds"))
            if "duration" in (left.kind, right.kind):
                return VType("duration", literal=left.literal and right.literal)
            rate = right.rate if left.adapts else left.rate
        elif op == "*":
            rate = left.rate + right.rate
        else:
            rate = left.rate - right.rate
        kind = "int" if left.kind == right.kind == "int" and op not in ("/", "%") else "float"
        if op == "%":
            kind = "int" if left.kind == right.kind == "int" else "float"
        return VType(kind, rate=rate, literal=left.literal and right.literal)

    def comparison(self, expr: ast.BinOp, left: VType, right: VType) -> None:
        op = expr.op
        if UNKNOWN in (left, right):
            return
        if op in ("=~", "!~"):
            self.regex(expr, left)
            return
        kinds = {left.kind, right.kind}
        if kinds <= {"int", "float", "duration"}:
            if _units_clash(left, right):
                self.report(self.unit_error(expr, left, right, "compares"))
            return
        if len(kinds) == 1 and kinds & {"string", "bool", "time"}:
            if op not in ("=", "!=") and kinds != {"time"}:
                self.report(
                    error(
                        "RMV311",
                        f"`{op}` does not order {left.kind}s",
                        expr.span,
                        label=f"{left.describe()} {op} {right.describe()}",
                        help="compare them with `=` or `!=`",
                    )
                )
            return
        self.report(
            error(
                "RMV311",
                f"cannot compare {left.describe()} with {right.describe()}",
                expr.span,
                label=f"{left.describe()} {op} {right.describe()}",
                secondary=[
                    Label(expr.left.span, left.describe()),
                    Label(expr.right.span, right.describe()),
                ],
            )
        )

    def regex(self, expr: ast.BinOp, left: VType) -> None:
        if left.kind != "string":
            self.report(self.operand_error(expr.op, expr.left, left, "a string"))
        if not isinstance(expr.right, ast.StringLit):
            self.report(
                error(
                    "RMV319",
                    f"`{expr.op}` needs a regular expression written as a string",
                    expr.right.span,
                    label="not a string",
                    help='e.g. `Name =~ "^car_[0-9]+$"`',
                )
            )
            return
        try:
            re.compile(expr.right.value)
        except re.error as exc:
            self.report(
                error(
                    "RMV319",
                    f"invalid regular expression: {exc.msg}",
                    expr.right.span,
                    label=f"at position {exc.pos}" if exc.pos is not None else "here",
                )
            )

    def call(self, expr: ast.Call) -> VType:
        name = expr.func.name
        arguments = [self.expression(a) for a in expr.args]
        signature = FUNCTIONS.get(name)
        if signature is None:
            return UNKNOWN  # reported by the names stage
        least, most, wants, result = signature
        if not least <= len(arguments) <= most:
            count = str(least) if least == most else f"{least} to {most}"
            self.report(
                error(
                    "RMV314",
                    f"`{name}` takes {count} argument{'s' if most > 1 else ''}, "
                    f"not {len(arguments)}",
                    expr.span,
                    label=f"{len(arguments)} given",
                )
            )
            return UNKNOWN
        first = arguments[0]
        if wants == _NUM and first.kind not in ("int", "float", "duration", "unknown"):
            self.report(self.argument_error(name, "numbers", first, expr.args[0].span))
            return UNKNOWN
        self.check_second_argument(expr, arguments)
        return self.call_result(result, first)

    def check_second_argument(self, expr: ast.Call, arguments: list[VType]) -> None:
        name = expr.func.name
        if len(arguments) < 2:
            return
        second = expr.args[1]
        if name in _TIME_ARGUMENT and not isinstance(second, ast.TimeLit):
            self.report(
                error(
                    "RMV316",
                    f"the second argument of `{name}` is a time unit such as `1s`",
                    second.span,
                    label="not a time",
                )
            )
        if name in _COUNT_ARGUMENT and not (
            isinstance(second, ast.NumberLit) and second.value.denominator == 1 and second.value > 0
        ):
            self.report(
                error(
                    "RMV313",
                    f"the second argument of `{name}` is a positive whole number",
                    second.span,
                    label="not a count",
                )
            )

    @staticmethod
    def call_result(result: str, first: VType) -> VType:
        if first is UNKNOWN:
            return UNKNOWN
        if result == "same":
            return replace(first, literal=False)
        if result == "rate-1":
            return VType("float", first.ros, first.rate - 1)
        if result == "rate+1":
            return VType("float", first.ros, first.rate + 1)
        if result == "float":
            return VType("float", first.ros, first.rate)
        if result == "duration":
            return DURATION
        return INT

    @staticmethod
    def operand_error(op: str, side: ast.Node, value: VType, wanted: str) -> Diagnostic:
        return error(
            "RMV310",
            f"`{op}` needs {wanted}, but this operand is {value.describe()}",
            side.span,
            label=value.describe(),
            help="turn a bool into 0 or 1 with `number(...)` in its variable"
            if value.kind == "bool"
            else None,
        )

    @staticmethod
    def unit_error(expr: ast.BinOp, left: VType, right: VType, verb: str) -> Diagnostic:
        help = (
            f"the left side is {_unit_text(left)}, the right side {_unit_text(right)}: "
            "compare like with like, or use a bare number, which takes the other side's unit"
        )
        minutes = next(
            (s for s in (expr.left, expr.right) if isinstance(s, ast.TimeLit)
             and s.time.unit == "m"),
            None,
        )  # fmt: skip
        if minutes is not None:
            help += f"; `{minutes.time.text}` is in minutes (`m`): for metres, write the number"
        return error(
            "RMV315",
            f"{verb} {left.describe()} with {right.describe()}",
            expr.span,
            label="different units",
            secondary=[
                Label(expr.left.span, _unit_text(left)),
                Label(expr.right.span, _unit_text(right)),
            ],
            help=help,
        )

    # ---- alerts ----

    def check_alert(self, alert: ast.AlertDecl) -> None:
        for level in alert.levels:
            self.condition(level.condition, f"the `{level.severity.name}` condition")
            if level.reset is None:
                continue
            self.condition(level.reset, f"the `{level.severity.name}` reset condition")
            measured = ast.names_in(level.condition)
            reset = ast.names_in(level.reset)
            foreign = sorted(reset - measured)
            if foreign or not reset:
                self.report(
                    error(
                        "RMV317",
                        f"the reset of `{level.severity.name}` watches "
                        + (", ".join(f"`{n}`" for n in foreign) if foreign else "no measurement")
                        + ", not what the condition watches "
                        + f"({', '.join(sorted(measured)) or 'nothing'})",
                        level.reset.span,
                        label="a different measurement",
                        secondary=[Label(level.condition.span, "the condition")],
                        help="an alert resets on the measurement that raised it",
                    )
                )

    # ---- properties ----

    def check_property(self, prop: ast.PropertyDecl) -> None:
        formula = prop.formula
        if formula is None:
            return
        for node in fm.walk(formula):
            if isinstance(node, fm.Compare):
                self.compare_terms(node)
        horizon = self.horizon(formula)
        if horizon is None:
            return
        self.info.horizons[prop.name.name] = horizon
        window = next((s for s in prop.settings if s.key.name == "window"), None)
        if window is None or not isinstance(window.value, ast.TimeLit):
            return
        seconds = window.value.time.seconds()
        if seconds is not None and seconds < horizon.total:
            self.report(
                error(
                    "RMV318",
                    f"the window of `{prop.name.name}` ({window.value.time.text}) is shorter than "
                    f"its horizon ({seconds_text(horizon.total)})",
                    window.value.span,
                    label=f"the formula looks {seconds_text(horizon.future)} ahead"
                    + (f" and {seconds_text(horizon.past)} back" if horizon.past else ""),
                    secondary=[Label(formula.span, "this formula")],
                    help=f"set `window = {seconds_text(horizon.total)}` or more",
                )
            )

    def term_unit(self, term: fm.Term) -> int | None:
        """The time exponent of a term: 1 for a duration, 0 for a plain number,
        None for a bare number that the spec's time unit makes a duration."""
        match term:
            case fm.Duration():
                return 1
            case fm.Number():
                if term.time is not None:
                    return 1
                return None if self.model.time_unit is not None else 0
            case fm.Arith():
                left, right = self.term_unit(term.left), self.term_unit(term.right)
                if term.op == "*":
                    return (
                        (left or 0) + (right or 0) if None not in (left, right) else (left or right)
                    )
                return left if left is not None else right
        return 0

    def compare_terms(self, node: fm.Compare) -> None:
        pairs: list[tuple[fm.Term, fm.Term]] = [(node.left, node.right)]
        for term in (node.left, node.right):
            pairs += [(t.left, t.right) for t in _sums(term)]
        for left, right in pairs:
            units = (self.term_unit(left), self.term_unit(right))
            if None in units or units[0] == units[1]:
                continue
            self.report(
                error(
                    "RMV315",
                    "compares a duration with a plain number"
                    if 0 in units and 1 in units
                    else "compares terms of different time units",
                    Span(left.span.path, left.span.start, right.span.end),
                    label="durations are times",
                    secondary=[
                        Label(left.span, _unit_word(units[0])),
                        Label(right.span, _unit_word(units[1])),
                    ],
                    help="give the number a unit (`4s`), or declare `time unit s` for the spec",
                )
            )
            return

    def horizon(self, formula: fm.Formula | fm.Term) -> Horizon | None:
        unit = self.model.time_unit
        match formula:
            case fm.Temporal():
                if formula.bound is None:
                    return None
                length = formula.bound.value.seconds(unit)
                parts = [self.horizon(c) for c in formula.children()]
                if length is None or None in parts:
                    return None
                future = max(p.future for p in parts if p)
                past = max(p.past for p in parts if p)
                if formula.op in ("until", "eventually", "always"):
                    return Horizon(future + length, past)
                return Horizon(future, past + length)
            case fm.Duration():
                length = formula.window.seconds(unit)
                body = self.horizon(formula.body)
                if length is None or body is None:
                    return None
                return Horizon(body.future + length, body.past)
        parts = [self.horizon(c) for c in formula.children()]
        if None in parts:
            return None
        return Horizon(
            max((p.future for p in parts if p), default=Fraction(0)),
            max((p.past for p in parts if p), default=Fraction(0)),
        )


def _units_clash(left: VType, right: VType) -> bool:
    return not (left.adapts or right.adapts) and left.exponent != right.exponent


def _unit_text(value: VType) -> str:
    exponent = value.exponent
    if exponent == 0:
        return "a plain number (no unit)"
    if exponent == 1:
        return "a time (seconds)"
    if exponent == -1:
        return "a rate (per second)"
    return f"in seconds^{exponent}"


def _sums(term: fm.Term) -> Iterator[fm.Arith]:
    """The `+` and `-` of a term, not looking inside duration bodies."""
    stack = [term]
    while stack:
        node = stack.pop()
        if isinstance(node, fm.Arith):
            if node.op in "+-":
                yield node
            stack += [node.right, node.left]


def _unit_word(unit: int | None) -> str:
    return {0: "a plain number", 1: "a duration"}.get(unit or 0, f"time^{unit}")


def seconds_text(value: Fraction) -> str:
    from rmvdsl.numbers import decimal

    return f"{decimal(value)}s"


def previous_name(node: ast.Node) -> str:
    if isinstance(node, ast.Segment):
        return node.field_name.name
    if isinstance(node, ast.Ident):
        return node.name
    return "?"


def check_types(
    model: Model, config: TypeConfig | None = None, spec_folder: str = "."
) -> tuple[TypeInfo, list[Diagnostic]]:
    return TypeChecker(model, config or TypeConfig(), spec_folder).run()
