"""Types of expressions (stage 3, a part of TypeChecker): operators, functions and
units in the conditions of events and alerts."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import replace

from rmvdsl.check.fieldpaths import FieldPaths
from rmvdsl.check.vtypes import (
    BOOL,
    DURATION,
    INT,
    UNKNOWN,
    VType,
)
from rmvdsl.grammar import ast
from rmvdsl.lang import builtins
from rmvdsl.lang.diagnostics import Diagnostic, Label, error
from rmvdsl.runtime.values import literal


class ExpressionTypes(FieldPaths):
    """What an expression's operands and functions must be, and what it gives."""

    # TypeChecker's: the type of a name an expression reads.
    name_type: Callable[[str], VType]

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
