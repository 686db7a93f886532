"""The RMTLD3 formula tree, shared by the parser, the checker and the evaluators.

Both surface syntaxes (the .rmv infix form and rmtld3synth's LaTeX form) build
these nodes. Spans do not take part in equality, so two formulas are equal when
they mean the same tree wherever they were written.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from fractions import Fraction

from rmvdsl.lang.source import NO_SPAN, Span

# The temporal operators that look ahead: with no bound, a verdict could wait for
# ever, so they need one; the past ones may go without.
FUTURE = frozenset({"until", "eventually", "always"})

# Time units and their length in seconds, exact.
TIME_UNITS: dict[str, Fraction] = {
    "ns": Fraction(1, 10**9),
    "us": Fraction(1, 10**6),
    "ms": Fraction(1, 1000),
    "s": Fraction(1),
    "m": Fraction(60),
    "h": Fraction(3600),
    "d": Fraction(86400),
    "w": Fraction(604800),
}


@dataclass(frozen=True)
class TimeValue:
    """A time written in the source: a number and a unit (None: the spec's time unit)."""

    value: Fraction
    unit: str | None
    text: str
    span: Span = field(default=NO_SPAN, compare=False)

    def seconds(self, default_unit: str | None = None) -> Fraction | None:
        unit = self.unit or default_unit
        if unit is None or unit not in TIME_UNITS:
            return None
        return self.value * TIME_UNITS[unit]


@dataclass(frozen=True)
class Bound:
    """A time bound of a temporal operator: `<`, `<=` or `=` a time value."""

    op: str
    value: TimeValue
    span: Span = field(default=NO_SPAN, compare=False)


class Formula:
    span: Span

    def children(self) -> Iterator[Formula | Term]:
        return iter(())


class Term:
    span: Span

    def children(self) -> Iterator[Formula | Term]:
        return iter(())


@dataclass(frozen=True)
class Prop(Formula):
    name: str
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Const(Formula):
    value: bool
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Not(Formula):
    operand: Formula
    span: Span = field(default=NO_SPAN, compare=False)

    def children(self) -> Iterator[Formula | Term]:
        yield self.operand


@dataclass(frozen=True)
class Binary(Formula):
    """`and`, `or`, `->` (implies) and `<->` (iff)."""

    op: str
    left: Formula
    right: Formula
    span: Span = field(default=NO_SPAN, compare=False)

    def children(self) -> Iterator[Formula | Term]:
        yield self.left
        yield self.right


@dataclass(frozen=True)
class Temporal(Formula):
    """`until` / `since` (two operands) and the unary `eventually`, `always`, `once`,
    `historically` (left is None). `bound` is None only when the source omitted it,
    which the checker reports."""

    op: str
    bound: Bound | None
    left: Formula | None
    right: Formula
    span: Span = field(default=NO_SPAN, compare=False)

    def children(self) -> Iterator[Formula | Term]:
        if self.left is not None:
            yield self.left
        yield self.right


@dataclass(frozen=True)
class Compare(Formula):
    """A comparison between two duration terms: `<`, `<=`, `>`, `>=`, `==`, `!=`."""

    op: str
    left: Term
    right: Term
    span: Span = field(default=NO_SPAN, compare=False)

    def children(self) -> Iterator[Formula | Term]:
        yield self.left
        yield self.right


@dataclass(frozen=True)
class Number(Term):
    """A constant; `time` is set when it was written with a unit (`4s`)."""

    value: Fraction
    time: TimeValue | None = None
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Duration(Term):
    """`duration[T](phi)`, rmtld3synth's `\\int^{T} phi`: how long phi holds in [t, t+T)."""

    window: TimeValue
    body: Formula
    span: Span = field(default=NO_SPAN, compare=False)

    def children(self) -> Iterator[Formula | Term]:
        yield self.body


@dataclass(frozen=True)
class Arith(Term):
    """`+`, `-` and `*` on terms."""

    op: str
    left: Term
    right: Term
    span: Span = field(default=NO_SPAN, compare=False)

    def children(self) -> Iterator[Formula | Term]:
        yield self.left
        yield self.right


def walk(node: Formula | Term) -> Iterator[Formula | Term]:
    """Every node of a formula, parents before children."""
    stack: list[Formula | Term] = [node]
    while stack:
        current = stack.pop()
        yield current
        stack.extend(reversed(list(current.children())))


def propositions(node: Formula | Term) -> list[Prop]:
    return [n for n in walk(node) if isinstance(n, Prop)]
