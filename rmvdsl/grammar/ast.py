"""The immutable syntax tree of a .rmv spec.

Every node is a frozen dataclass with a `span` that does not take part in equality
(so `parse(fmt(x)) == parse(x)` compares meaning, not layout). `children()` yields
the sub-nodes; `dataclasses.replace` gives functional update.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from fractions import Fraction
from typing import TYPE_CHECKING, Any

from rmvdsl.grammar.formula import Formula, TimeValue
from rmvdsl.grammar.shift import moved_field, tree_fields
from rmvdsl.lang.source import NO_SPAN, Span


class Node:
    span: Span

    def children(self) -> Iterator[Node]:
        return iter(_children(self))

    if not TYPE_CHECKING:  # mypy would take every attribute of a node for Any

        def __getattr__(self, name: str) -> Any:
            """Only for a field not there: a moved declaration's sub-trees, moved
            when first read (rmvdsl.grammar.shift)."""
            return moved_field(self, name)


# The fields of a node class that may hold nodes, by their annotations, found once
# per class (an editor walks the tree at every keystroke: `dataclasses.fields` per
# visit was a tenth of a check).
_child_fields = tree_fields


@dataclass(frozen=True)
class Ident(Node):
    name: str
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class StringLit(Node):
    value: str
    span: Span = field(default=NO_SPAN, compare=False)
    # Offset in the file of each character of `value` (escapes make them differ).
    offsets: tuple[int, ...] = field(default=(), compare=False, repr=False)


@dataclass(frozen=True)
class NumberLit(Node):
    value: Fraction
    text: str
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class TimeLit(Node):
    time: TimeValue
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class RateLit(Node):
    hertz: Fraction
    text: str
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class BoolLit(Node):
    value: bool
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class NameValue(Node):
    ident: Ident
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class EnvRef(Node):
    variable: StringLit
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class ListValue(Node):
    items: tuple[Value, ...]
    span: Span = field(default=NO_SPAN, compare=False)


Value = StringLit | NumberLit | TimeLit | RateLit | BoolLit | NameValue | EnvRef | ListValue


@dataclass(frozen=True)
class Setting(Node):
    key: Ident
    value: Value
    span: Span = field(default=NO_SPAN, compare=False)


# ---- expressions (events and alerts) ----


@dataclass(frozen=True)
class BinOp(Node):
    op: str
    left: Expr
    right: Expr
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class UnaryOp(Node):
    op: str
    operand: Expr
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Call(Node):
    func: Ident
    args: tuple[Expr, ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class NameRef(Node):
    ident: Ident
    span: Span = field(default=NO_SPAN, compare=False)


Expr = BinOp | UnaryOp | Call | NameRef | NumberLit | StringLit | TimeLit | BoolLit


# ---- declarations ----


@dataclass(frozen=True)
class Decl(Node):
    """Common base: every declaration may carry a doc comment."""

    # A moved copy's sub-trees are moved when one is first read (rmvdsl.grammar.shift):
    # a check reuses most declarations' findings and never reads them.
    _moved_on_read = True


@dataclass(frozen=True)
class SystemDecl(Decl):
    name: Ident
    title: StringLit | None
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class ImportDecl(Decl):
    path: StringLit
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class TimeUnitDecl(Decl):
    unit: Ident
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class RosDecl(Decl):
    distro: Ident
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class MessagesDecl(Decl):
    """A folder of .msg files, relative to the spec's folder."""

    path: StringLit
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class RetentionDecl(Node):
    name: Ident
    settings: tuple[Setting, ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class DownsampleDecl(Node):
    name: Ident
    settings: tuple[Setting, ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class DatabaseDecl(Decl):
    name: Ident | None
    settings: tuple[Setting, ...]
    retentions: tuple[RetentionDecl, ...]
    downsamples: tuple[DownsampleDecl, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class MsgType(Node):
    parts: tuple[Ident, ...]
    span: Span = field(default=NO_SPAN, compare=False)

    @property
    def text(self) -> str:
        return "/".join(p.name for p in self.parts)


@dataclass(frozen=True)
class TopicDecl(Decl):
    name: Ident
    msg_type: MsgType
    path: StringLit
    qos: tuple[Setting, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)

    @property
    def time_setting(self) -> NameValue | None:
        """The block's `time = receipt|header`, as written (None: not given)."""
        for setting in self.qos:
            if setting.key.name == "time" and isinstance(setting.value, NameValue):
                return setting.value
        return None


@dataclass(frozen=True)
class Segment(Node):
    """One step of a field path: a field name, optionally indexed by `[N]` or `[*]`."""

    field_name: Ident
    index: int | str | None
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class FieldRef(Node):
    topic: Ident
    segments: tuple[Segment, ...]
    span: Span = field(default=NO_SPAN, compare=False)

    @property
    def text(self) -> str:
        parts = []
        for segment in self.segments:
            index = "" if segment.index is None else f"[{segment.index}]"
            parts.append(segment.field_name.name + index)
        return ".".join(parts)


@dataclass(frozen=True)
class VarDecl(Decl):
    name: Ident
    source: FieldRef
    aggregate: Ident | None
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class GroupBy(Node):
    interval: TimeLit | None
    offset: TimeLit | None
    tags: tuple[StringLit | Ident, ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Resample(Node):
    every: TimeLit | None
    for_: TimeLit | None
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Clause(Node):
    """One clause of an event: kind is where|group|fill|order|limit|resample|range."""

    kind: str
    value: Node
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class EventDecl(Decl):
    """`event N = expr ...` (a value event, a measurement) or `event N when cond ...`
    (a boolean event)."""

    name: Ident
    boolean: bool
    expr: Expr
    clauses: tuple[Clause, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)

    def clause(self, kind: str) -> Clause | None:
        return next((c for c in self.clauses if c.kind == kind), None)


@dataclass(frozen=True)
class Arg(Node):
    """An action argument: positional (key None) or `key = value`."""

    key: Ident | None
    value: Value
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Action(Node):
    kind: Ident
    args: tuple[Arg, ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class AlertLevel(Node):
    severity: Ident
    condition: Expr
    reset: Expr | None
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class AlertDecl(Decl):
    name: Ident
    levels: tuple[AlertLevel, ...]
    message: StringLit | None
    settings: tuple[Setting, ...]
    actions: tuple[Action, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Transition(Node):
    source: Ident
    dest: Ident
    input: Ident
    output: Ident | None
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class TransducerDecl(Decl):
    name: Ident
    states: tuple[Ident, ...]
    initial: Ident | None
    finals: tuple[Ident, ...]
    complete: bool
    transitions: tuple[Transition, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class LatexFormula(Node):
    """A formula written in rmtld3synth's LaTeX notation; `formula` is its parse
    (None when it does not parse)."""

    source: StringLit
    formula: Formula | None = field(default=None, compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class InfixFormula(Node):
    formula: Formula
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class PropertyDecl(Decl):
    name: Ident
    body: InfixFormula | LatexFormula
    settings: tuple[Setting, ...]
    actions: tuple[Action, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)

    @property
    def formula(self) -> Formula | None:
        return self.body.formula


@dataclass(frozen=True)
class WhitelistDecl(Decl):
    """`whitelist <topic> { publishers: ... subscribers: ... }`; the target is a
    topic's short name or a quoted ROS topic name (patterns allowed)."""

    target: Ident | StringLit
    publishers: tuple[StringLit, ...] | None
    subscribers: tuple[StringLit, ...] | None
    actions: tuple[Action, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class NodeDecl(Decl):
    """`node "/name" { publishes: ... subscribes: ... }`: a whitelist per node."""

    name: StringLit
    publishes: tuple[StringLit, ...] | None
    subscribes: tuple[StringLit, ...] | None
    actions: tuple[Action, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class IntrusionDecl(Decl):
    """Global settings and actions on intrusion."""

    settings: tuple[Setting, ...]
    actions: tuple[Action, ...]
    doc: str = field(default="", compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Comment:
    """A `//` comment (doc comments start with `///`); kept for the formatter."""

    text: str
    span: Span


@dataclass(frozen=True)
class Spec(Node):
    path: str
    items: tuple[Decl, ...]
    comments: tuple[Comment, ...] = field(default=(), compare=False)
    span: Span = field(default=NO_SPAN, compare=False)


def walk(*roots: Node) -> list[Node]:
    """Every node below the roots, parents first, left to right."""
    out: list[Node] = []
    stack = list(reversed(roots))
    while stack:
        current = stack.pop()
        out.append(current)
        stack.extend(reversed(_children(current)))
    return out


def _children(node: Node) -> list[Node]:
    out: list[Node] = []
    values = node.__dict__
    for name in _child_fields(type(node)):
        value = values[name] if name in values else getattr(node, name)  # moved on read
        if isinstance(value, Node):
            out.append(value)
        elif type(value) is tuple:
            out.extend([v for v in value if isinstance(v, Node)])
    return out


def names_in(node: Node) -> set[str]:
    """The names an expression reads."""
    return {n.ident.name for n in walk(node) if isinstance(n, NameRef)}
