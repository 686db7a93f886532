"""InfluxQL and TICKscript as the kapacitor target writes them: the one quoting
function per kind of literal in each language, durations, and expressions from the
resolved spec (exactly, or Unsupported)."""

from __future__ import annotations

from fractions import Fraction

from rmvdsl.runtime import spec as ir
from rmvdsl.targets import TargetError


class BuildError(TargetError):
    """A spec this target cannot express."""


class Unsupported(Exception):
    """An expression with no exact InfluxQL or TICKscript counterpart."""


# ---- InfluxQL ----


def influxql_identifier(name: str) -> str:
    """Any name as an InfluxQL identifier: double quotes, with `\\`, `"` and a
    newline escaped (influxql's scanner reads quoted identifiers as strings)."""
    text = name.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{text}"'


def influxql_string(value: str) -> str:
    """Any text as an InfluxQL string literal: single quotes, `\\`, `'` and a
    newline escaped."""
    text = value.replace("\\", "\\\\").replace("'", "\\'").replace("\n", "\\n")
    return f"'{text}'"


# Units from the largest: a duration is written as a whole number of one unit.
_INFLUXQL_UNITS = (("w", 604800), ("d", 86400), ("h", 3600), ("m", 60), ("s", 1),
                   ("ms", Fraction(1, 10**3)), ("u", Fraction(1, 10**6)),
                   ("ns", Fraction(1, 10**9)))  # fmt: skip


def _whole(seconds: Fraction, units: tuple[tuple[str, int | Fraction], ...]) -> str | None:
    """The duration as a whole number of the largest unit that divides it."""
    for unit, size in units:
        count = Fraction(seconds) / size
        if count.denominator == 1 and count >= 1:
            return f"{count.numerator}{unit}"
    return None


def influxql_duration(seconds: Fraction | None) -> str:
    """A duration as InfluxQL writes it (`90s`, `100ms`); `INF` for forever."""
    if seconds is None:
        return "INF"
    if seconds == 0:
        return "0s"
    text = _whole(Fraction(seconds), _INFLUXQL_UNITS)
    if text is None:
        raise BuildError(f"{seconds} s is not a whole number of nanoseconds")
    return text


_INFLUXQL_OPS = {"=": "=", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">=",
                 "+": "+", "-": "-", "*": "*", "/": "/", "%": "%", "&": "&", "|": "|",
                 "^": "^", "and": "AND", "or": "OR"}  # fmt: skip


def influxql_expression(expr: ir.Expr) -> str:
    """An event's expression (or `where` condition) in InfluxQL, parenthesised so
    the tree is the one the spec holds whatever InfluxQL's precedence."""
    match expr:
        case ir.Number():
            return expr.text
        case ir.String():
            return influxql_string(expr.value)
        case ir.Boolean():
            return "true" if expr.value else "false"
        case ir.Time():
            return influxql_duration(expr.seconds)
        case ir.Ref():
            return influxql_identifier(expr.name)
        case ir.Unary(op="-"):
            return f"-{_influxql_operand(expr.operand)}"
        case ir.Unary():
            raise Unsupported(f"InfluxQL has no `{expr.op}`")
        case ir.Binary():
            op = _INFLUXQL_OPS.get(expr.op)
            if op is None:
                raise Unsupported(f"InfluxQL has no `{expr.op}`")
            left, right = _influxql_operand(expr.left), _influxql_operand(expr.right)
            return f"{left} {op} {right}"
        case ir.Call():
            args = ", ".join(influxql_expression(a) for a in expr.args)
            return f"{expr.function}({args})"
    raise Unsupported(f"no InfluxQL for {type(expr).__name__}")


def _influxql_operand(expr: ir.Expr) -> str:
    text = influxql_expression(expr)
    return f"({text})" if isinstance(expr, (ir.Binary, ir.Unary)) else text


# ---- TICKscript ----


def tick_string(value: str) -> str:
    """Any text as a TICKscript string literal, as Kapacitor's lexer reads one
    (tick/ast/lex.go): single quotes where only `\\'` is an escape; a text that
    ends in a backslash cannot end a single-quoted literal, so it takes triple
    quotes (no escapes at all), unless it also holds `'''` or ends in a quote."""
    if not value.endswith("\\"):
        return "'" + value.replace("'", "\\'") + "'"
    if "'''" not in value and not value.endswith("'"):
        return f"'''{value}'''"
    raise BuildError(f"{value!r} cannot be written as a TICKscript string")


def tick_reference(name: str) -> str:
    """A field or tag as a TICKscript reference (double quotes, `\\"` escaped)."""
    if name.endswith("\\") or "\n" in name:
        raise BuildError(f"{name!r} cannot be a TICKscript reference")
    return '"' + name.replace('"', '\\"') + '"'


def go_template_text(text: str) -> str:
    """Text that Kapacitor's `.message()` and `.id()` (Go templates) print as is:
    every `{{` becomes an action printing `{{`; a trailing backslash is followed by
    an empty action, so the literal around it can end."""
    text = text.replace("{{", '{{ "{{" }}')
    return text + '{{ "" }}' if text.endswith("\\") else text


_TICK_UNITS = (("w", 604800), ("d", 86400), ("h", 3600), ("m", 60), ("s", 1),
               ("ms", Fraction(1, 10**3)), ("u", Fraction(1, 10**6)))  # fmt: skip


def tick_duration(seconds: Fraction) -> str:
    """A TICKscript duration literal: one integer and one unit (`90s`, never
    `1m30s` or `1.5m`); TICKscript has no nanoseconds."""
    text = _whole(Fraction(seconds), _TICK_UNITS)
    if text is None:
        raise BuildError(f"{seconds} s is not a whole number of microseconds")
    return text


_TICK_OPS = {"=": "==", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">=",
             "+": "+", "-": "-", "*": "*", "and": "AND", "or": "OR"}  # fmt: skip


def tick_expression(expr: ir.Expr) -> str:
    """An alert condition as a TICKscript lambda expression. InfluxQL's `/` (always
    a division of doubles) divides two `float()`s; what has no exact counterpart
    (functions, `%`, bitwise operators) is Unsupported."""
    match expr:
        case ir.Number():
            return expr.text
        case ir.String():
            return tick_string(expr.value)
        case ir.Boolean():
            return "TRUE" if expr.value else "FALSE"
        case ir.Time():
            return tick_duration(expr.seconds)
        case ir.Ref():
            return tick_reference(expr.name)
        case ir.Unary():
            sign = "-" if expr.op == "-" else "!"
            return f"{sign}{_tick_operand(expr.operand)}"
        case ir.Binary(op="/"):
            left, right = tick_expression(expr.left), tick_expression(expr.right)
            return f"float({left}) / float({right})"
        case ir.Binary():
            op = _TICK_OPS.get(expr.op)
            if op is None:
                raise Unsupported(f"TICKscript has no exact `{expr.op}`")
            return f"{_tick_operand(expr.left)} {op} {_tick_operand(expr.right)}"
    raise Unsupported(f"TICKscript lambdas have no `{getattr(expr, 'function', expr)}`")


def _tick_operand(expr: ir.Expr) -> str:
    text = tick_expression(expr)
    return f"({text})" if isinstance(expr, (ir.Binary, ir.Unary)) else text
