"""TICKscript's tree (pipelines and lambda expressions) as the kapacitor target
writes it, the one quoting rule for each kind of literal (as Kapacitor's lexer,
tick/ast/lex.go, reads them), and the printer."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from rmvdsl.dialects.common import Binary, Call, Literal, Text, Unary, printed
from rmvdsl.dialects.influxql import whole


class TickError(ValueError):
    """A text that is not TICKscript, or a value TICKscript cannot hold."""


# ---- quoting ----


def string(value: str) -> str:
    """Any text as a string literal: single quotes where only `\\'` is an escape;
    a text that ends in a backslash cannot end a single-quoted literal, so it takes
    triple quotes (no escapes at all), unless it also holds `'''` or ends in a quote."""
    if not value.endswith("\\"):
        return "'" + value.replace("'", "\\'") + "'"
    if "'''" not in value and not value.endswith("'"):
        return f"'''{value}'''"
    raise TickError(f"{value!r} cannot be written as a TICKscript string")


def reference(name: str) -> str:
    """A field or tag as a reference (double quotes, `\\"` escaped)."""
    if name.endswith("\\") or "\n" in name:
        raise TickError(f"{name!r} cannot be a TICKscript reference")
    return '"' + name.replace('"', '\\"') + '"'


def go_template_text(text: str) -> str:
    """Text that `.message()` and `.id()` (Go templates) print as is: every `{{`
    becomes an action printing `{{`; a trailing backslash is followed by an empty
    action, so the literal around it can end."""
    text = text.replace("{{", '{{ "{{" }}')
    return text + '{{ "" }}' if text.endswith("\\") else text


UNITS: tuple[tuple[str, int | Fraction], ...] = (
    ("w", 604800), ("d", 86400), ("h", 3600), ("m", 60), ("s", 1),
    ("ms", Fraction(1, 10**3)), ("u", Fraction(1, 10**6)),
)  # fmt: skip


def duration(seconds: Fraction) -> str:
    """A duration literal: one integer and one unit (`90s`, never `1m30s` or
    `1.5m`); TICKscript has no nanoseconds."""
    text = whole(Fraction(seconds), UNITS)
    if text is None:
        raise TickError(f"{seconds} s is not a whole number of microseconds")
    return text


# ---- the tree ----


@dataclass(frozen=True)
class Reference:
    name: str


@dataclass(frozen=True)
class Identifier:
    """A bare word as an argument (a variable, `stream`)."""

    name: str


@dataclass(frozen=True)
class Lambda:
    body: Expr


Expr = Reference | Literal | Text | Binary | Unary | Call | Identifier | Lambda


@dataclass(frozen=True)
class Step:
    """`|name(args)` (a node, `chain` "|"), `.name(args)` (a property), `@name(args)`."""

    chain: str
    name: str
    args: tuple[Expr, ...] = ()


@dataclass(frozen=True)
class Pipeline:
    """`var NAME = SOURCE steps`, or the bare chain when `var` is None."""

    source: str
    steps: tuple[Step, ...]
    var: str | None = None


@dataclass(frozen=True)
class Dbrp:
    database: str
    retention: str


@dataclass(frozen=True)
class Var:
    """`var NAME = VALUE` where the value is not a pipeline (a lambda, a literal)."""

    name: str
    value: Expr


Statement = Pipeline | Dbrp | Var


# ---- the printer ----


def expression(expr: Expr) -> str:
    """An expression, operands parenthesised so the tree is the one printed."""
    return printed(expr, _own, string)


def _own(node: Expr) -> str | None:
    match node:
        case Reference():
            return reference(node.name)
        case Identifier():
            return node.name
        case Lambda():
            return f"lambda: {expression(node.body)}"
    return None


def statement(stmt: Statement) -> str:
    """A statement: a pipeline one step a line, nodes indented 4, properties 8."""
    if isinstance(stmt, Dbrp):
        return f"dbrp {reference(stmt.database)}.{reference(stmt.retention)}"
    if isinstance(stmt, Var):
        return f"var {stmt.name} = {expression(stmt.value)}"
    lines = [f"var {stmt.var} = {stmt.source}" if stmt.var else stmt.source]
    for step in stmt.steps:
        indent = "    " if step.chain == "|" else "        "
        args = ", ".join(expression(a) for a in step.args)
        lines.append(f"{indent}{step.chain}{step.name}({args})")
    return "\n".join(lines)
