"""Types (stage 3): every variable against real ROS message definitions, then
events, alerts and properties, with time units and property horizons.

Value types are in vtypes.py, the resolution of field paths in fieldpaths.py.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any, cast

from rmvdsl import builtins
from rmvdsl.bounded import Bounded
from rmvdsl.check.fieldpaths import FieldPaths
from rmvdsl.check.memo import MEMO_SIZE, Key, declaration_key
from rmvdsl.check.model import Kind, Model
from rmvdsl.check.msgtypes import (
    DEFAULT_DISTRO,
    DISTROS,
    FieldType,
    TypeRegistry,
    environment_folders,
)
from rmvdsl.check.typeinfo import Horizon, TypeInfo
from rmvdsl.check.vtypes import (
    BOOL,
    DURATION,
    FLOAT,
    INT,
    NUMERIC,
    STRING,
    UNKNOWN,
    VType,
    from_ros,
)
from rmvdsl.diagnostics import Diagnostic, Label, did_you_mean, error
from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.logic.compile import CompileError, compile_formula
from rmvdsl.runtime.rmtld3 import facts
from rmvdsl.runtime.values import literal
from rmvdsl.source import Span

__all__ = [
    "BOOL", "DURATION", "FLOAT", "INT", "NUMERIC", "STRING", "UNKNOWN",
    "Horizon", "TypeChecker", "TypeConfig", "TypeInfo", "VType", "check_types", "from_ros",
]  # fmt: skip


@dataclass(frozen=True)
class Typed:
    """What typing one declaration found when it found nothing wrong: what it
    looked up then (the type of each name it read; a variable's topic definition,
    message definitions and ROS distribution), its nodes' types (ast.walk's order),
    its result."""

    lookups: tuple[tuple[str, str, Any], ...]  # what was looked up (TypeChecker.noted)
    types: tuple[VType | None, ...]
    result: Any


# Each clean declaration's types, for incremental checks (rmvdsl.check.memo).
TYPED: Bounded[Key, Typed] = Bounded(MEMO_SIZE)


@dataclass
class TypeConfig:
    """Where the ROS distribution and message folders come from (the command line
    wins over the spec, the spec over rmv.toml)."""

    ros: str | None = None
    messages: tuple[str, ...] = ()
    use_environment: bool = True


class TypeChecker(FieldPaths):
    def __init__(
        self, model: Model, config: TypeConfig, spec_folder: str, incremental: bool = False
    ) -> None:
        self.model = model
        self.config = config
        self.spec_folder = spec_folder
        self.incremental = incremental
        self.diagnostics: list[Diagnostic] = []
        self.info = TypeInfo(TypeRegistry(self._distro()))
        self._event_stack: set[str] = set()
        # What each declaration being typed looked up (innermost last), remembered.
        self._reads: list[list[tuple[str, str, Any]]] = []

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
        model = self.model
        if self.incremental:
            TYPED.fit(
                len(model.variables) + len(model.events) + len(model.alerts) + len(model.properties)
            )
        self.load_messages()
        for name, topic in model.topics.items():
            self.info.topics[name] = self.resolve_topic(topic)
        for name, variable in model.variables.items():
            self.info.variables[name] = self.typed_variable(variable)
        for name in model.events:
            self.event_type(name)
        for alert in model.alerts.values():
            self.check_alert(alert)
        for prop in model.properties.values():
            self.check_property(prop)
        return self.info, self.diagnostics

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
        value = self.remembered(decl, lambda: self.type_event(decl))
        self._event_stack.discard(name)
        self.info.events[name] = value
        return value

    def typed_variable(self, variable: ast.VarDecl) -> VType:
        name = variable.name.name

        def typed() -> tuple[VType, tuple[FieldType, ...] | None]:
            self.noted("distro", "", self.info.registry.distro)
            value = self.type_variable(variable)
            return value, self.info.paths.get(name)

        value, path = self.remembered(variable, typed)
        if path is not None:
            self.info.paths[name] = path
        return cast("VType", value)

    def type_event(self, decl: ast.EventDecl) -> VType:
        value = self.expression(decl.expr)
        where = decl.clause("where")
        if where is not None:
            self.condition(where.value, "a `where` clause")
        if decl.boolean:
            self.condition(decl.expr, f"the condition of `{decl.name.name}`", value)
            value = BOOL
        return value

    def remembered(self, decl: ast.Node, typed: Callable[[], Any]) -> Any:
        """typed(), or what it found the last time this text was typed, when every
        lookup it made still gives the same answer (an incremental check's)."""
        key = declaration_key(self.model, decl) if self.incremental else None
        if key is None:
            return typed()
        known = TYPED.get(key)
        if known is not None and self.still_holds(known):
            if known.types:
                self.info.unplaced.append((decl, known.types))
            return known.result
        found = len(self.diagnostics)
        self._reads.append([])
        try:
            result = typed()
        finally:
            reads = self._reads.pop()
        if len(self.diagnostics) == found:
            expressions = self.info.expressions
            types = tuple([expressions.get(id(node)) for node in ast.walk(decl)])
            kept = types if any(t is not None for t in types) else ()
            TYPED.put(key, Typed(tuple(reads), kept, result))
        return result

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
        value = self.info.expressions[id(expr)] = self._expression(expr)
        return value

    def _expression(self, expr: ast.Node) -> VType:
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

    def still_holds(self, known: Typed) -> bool:
        """Whether every lookup of an earlier typing gives what it gave then (the
        same type of a name; the very same definition, read once per file)."""
        for what, name, value in known.lookups:
            if what == "name":
                if self._name_type(name) != value:
                    return False
            elif self.looked_up(what, name) is not value:
                return False
        return True

    def looked_up(self, what: str, name: str) -> Any:
        if what == "topic":
            return self.info.topics.get(name)
        if what == "message":
            return self.info.registry.get(name)
        return self.info.registry.distro

    def noted(self, what: str, name: str, value: Any) -> None:
        """Remember a lookup of the declaration being typed (an incremental check's)."""
        if self._reads:
            self._reads[-1].append((what, name, value))

    def name_type(self, name: str) -> VType:
        value = self._name_type(name)
        self.noted("name", name, value)
        return value

    def _name_type(self, name: str) -> VType:
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
        signature = builtins.FUNCTIONS.get(name)
        if signature is None:
            return UNKNOWN  # reported by the names stage
        least, most = signature.least, signature.most
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
        numeric = first.kind in ("int", "float", "duration", "unknown")
        if signature.wants == "numeric" and not numeric:
            self.report(self.argument_error(name, "numbers", first, expr.args[0].span))
            return UNKNOWN
        self.check_second_argument(expr, signature.second)
        return self.call_result(signature.result, first)

    def check_second_argument(self, expr: ast.Call, kind: str | None) -> None:
        name = expr.func.name
        if len(expr.args) < 2:
            return
        second = expr.args[1]
        if kind == "time" and not isinstance(second, ast.TimeLit):
            self.report(
                error(
                    "RMV316",
                    f"the second argument of `{name}` is a time unit such as `1s`",
                    second.span,
                    label="not a time",
                )
            )
        if kind == "percent" and not (
            isinstance(second, ast.NumberLit) and 0 <= second.value <= 100
        ):
            self.report(
                error(
                    "RMV313",
                    f"the second argument of `{name}` is a percentile from 0 to 100",
                    second.span,
                    label="not a percentile",
                )
            )
        if kind == "count" and not (
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
        self.remembered(alert, lambda: self.type_alert(alert))

    def type_alert(self, alert: ast.AlertDecl) -> None:
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
        found = self.remembered(prop, lambda: self.type_property(prop))
        if found is not None:
            self.info.formulas[prop.name.name], self.info.horizons[prop.name.name] = found

    def type_property(self, prop: ast.PropertyDecl) -> Any:
        """The compiled formula and its horizon (None when it has none, or when it
        does not compile)."""
        formula = prop.formula
        if formula is None:
            return None
        for node in fm.walk(formula):
            if isinstance(node, fm.Compare):
                self.compare_terms(node)
        found = self.horizon(formula)
        if found is None:
            return None
        self.check_window(prop, formula, found[1])
        return found

    def check_window(self, prop: ast.PropertyDecl, formula: fm.Formula, horizon: Horizon) -> None:
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

    def horizon(self, formula: fm.Formula) -> tuple[Any, Horizon] | None:
        """The compiled formula and how far it looks ahead and back: the runtime's
        own traversal of it (rmvdsl.runtime.rmtld3.facts), kept for later stages."""
        try:
            compiled = compile_formula(formula, Fraction(1), self.model.time_unit)
        except CompileError:
            return None  # a bound without a unit or a bad term: the names stage said so
        found = facts(compiled)
        return compiled, Horizon(Fraction(found.future), Fraction(found.past))


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


def check_types(
    model: Model,
    config: TypeConfig | None = None,
    spec_folder: str = ".",
    incremental: bool = False,
) -> tuple[TypeInfo, list[Diagnostic]]:
    """The types stage; `incremental` reuses what earlier checks found in the
    declarations whose text has not changed (an editor's, rmvdsl.check.memo)."""
    return TypeChecker(model, config or TypeConfig(), spec_folder, incremental).run()
