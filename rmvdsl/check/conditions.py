"""Boolean events as z3 formulas, from the lowered expressions the runtime runs, with
the runtime's operators (rmvdsl.check.operators). A variable ranges
over its ROS type (an `int8` over -128..127, a `float64` over every double,
NaN included), and may have no value yet: each value has a presence flag, and a
condition is three-valued as in the runtime (Kleene's `and`/`or`, an event holds
where its condition is true; docs/semantics.md, "Absent values"). What z3 cannot
model exactly — a function of the data (`mean(V)`), a value event, a
regular-expression match — is a free value of its sort, so an answer "can hold" is
a possibility the spec leaves open and "never holds" is exact.

`Conditions.solve` asks z3 (rmvdsl.check.solving) about them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import z3

from rmvdsl.check.lowering import NotLowered, lower_expr
from rmvdsl.check.model import Model
from rmvdsl.check.operators import (
    apply,
    as_bool,
    constant,
    is_float,
    negate,
    number,
    transform,
    undefined_at,
)
from rmvdsl.check.solving import PRESENT, names_in, solve, verdict
from rmvdsl.check.types import TypeInfo
from rmvdsl.logic.terms import conjunction, disjunction, negation
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.functions import ELEMENTWISE
from rmvdsl.runtime.values import INTEGER_RANGES, literal

_ORDERS = ("<", "<=", ">", ">=")


ALWAYS = z3.BoolVal(True)


@dataclass(frozen=True)
class Term:
    """A value as the runtime holds it: `value` where `present`, else absent (the
    runtime's MISSING: a topic not yet published). A boolean term is three-valued:
    true where `present and value`, false where `present and not value`, unknown
    elsewhere (docs/semantics.md, "Absent values")."""

    value: Any
    present: Any = ALWAYS

    @property
    def true(self) -> Any:
        """Where the term is `True`: where a condition holds."""
        if z3.is_true(self.present):
            return as_bool(self.value)
        return conjunction([self.present, as_bool(self.value)])

    @property
    def false(self) -> Any:
        if z3.is_true(self.present):
            return negation(as_bool(self.value))
        return conjunction([self.present, negation(as_bool(self.value))])


def _both(left: Term | Kleene, right: Term | Kleene) -> Any:
    if z3.is_true(left.present):
        return right.present
    if z3.is_true(right.present):
        return left.present
    return conjunction([left.present, right.present])


@dataclass(frozen=True)
class Kleene:
    """A three-valued `and`/`or` as where it is true and where it is false, as built:
    the value and presence `Term` derives them from are made only when read (an
    event's condition reads neither, and they doubled the terms z3 was given)."""

    true: Any
    false: Any

    @property
    def value(self) -> Any:
        return self.true

    @property
    def present(self) -> Any:
        return disjunction([self.true, self.false])


def kleene(op: str, left: Term | Kleene, right: Term | Kleene) -> Term | Kleene:
    """`and`/`or` over three values, as rmvdsl.runtime.influx.kleene_and/or: false
    (true) decides an `and` (an `or`) whatever the other side is."""
    if op == "and":
        holds = conjunction([left.true, right.true])
        if _always(left) and _always(right):
            return Term(holds)
        return Kleene(holds, disjunction([left.false, right.false]))
    holds = disjunction([left.true, right.true])
    if _always(left) and _always(right):
        return Term(holds)
    return Kleene(holds, conjunction([left.false, right.false]))


def _always(term: Term | Kleene) -> bool:
    return isinstance(term, Term) and z3.is_true(term.present)


class Conditions:
    """The z3 formula of each boolean event; `symbols` names the free values."""

    def __init__(self, model: Model, types: TypeInfo | None) -> None:
        self.model = model
        self.types = types
        self.symbols: dict[str, Any] = {}
        self.domains: dict[str, list[Any]] = {}  # a variable's range, by its name
        self._inlining: set[str] = set()

    def of_event(self, name: str) -> Any:
        """Where the boolean event `name` holds: where its condition (and `where`)
        is true. An unknown condition does not hold, as in the runtime."""
        decl = self.model.events.get(name)
        if decl is None or not decl.boolean or name in self._inlining or self.types is None:
            return self.free(f"event {name}", "bool", may_be_absent=False).true
        self._inlining.add(name)
        try:
            # The typed trees the runtime evaluates (rmvdsl.check.lowering).
            condition = self.expr(lower_expr(self.model, self.types, decl.expr)).true
            where = decl.clause("where")
            if where is not None:
                lowered = lower_expr(self.model, self.types, where.value)
                condition = z3.And(condition, self.expr(lowered).true)
            return condition
        except (z3.Z3Exception, TypeError, AttributeError, NotLowered):
            # Sorts that do not fit (the types stage reports why): no claim at all.
            return self.free(f"event {name}", "bool", may_be_absent=False).true
        finally:
            self._inlining.discard(name)

    def event_question(self, name: str) -> str:
        """What `of_event(name)` builds, as text, without z3: the lowered trees of
        the event and of every boolean event it inlines (each Ref's kind and type
        in them), so a question about the event is keyed before any term is made
        (a re-check asks the cache first; building the terms cost more than the
        answers). Names are replaced by their order of first reading: events that
        say the same of other values (`X1 > 0.8` and `X2 > 0.8`, both float64) are
        one question (rmvdsl.logic.canonical does the same for properties)."""
        parts: list[str] = []
        self._question(name, (), parts, {})
        return "\n".join(parts)

    def _question(
        self, name: str, inlining: tuple[str, ...], parts: list[str], names: dict[str, str]
    ) -> None:
        decl = self.model.events.get(name)
        called = names.setdefault(name, f"n{len(names)}")
        if decl is None or not decl.boolean or name in inlining or self.types is None:
            parts.append(f"free event {called}")
            return
        try:
            trees = [lower_expr(self.model, self.types, decl.expr)]
            where = decl.clause("where")
            if where is not None:
                trees.append(lower_expr(self.model, self.types, where.value))
        except NotLowered:
            parts.append(f"unlowered event {called}")
            return
        parts.append(f"event {called}: " + " | ".join(_shape(tree, names) for tree in trees))
        for tree in trees:
            for ref in _refs(tree):
                inlined = self.model.events.get(ref.name)
                if (
                    ref.kind not in ("variable", "emitted")
                    and inlined is not None
                    and inlined.boolean
                ):
                    self._question(ref.name, (*inlining, name), parts, names)

    def solve(self, constraints: list[Any], values: bool = True) -> tuple[str, str]:
        """`solve` of these constraints, with the ranges of the
        variables they mention (only those: a question's cache key and its cost do
        not grow with the rest of the spec). Without `values`, only the verdict."""
        used = names_in(constraints)
        symbols = {name: self.symbols[name] for name in sorted(used) if name in self.symbols}
        return solve(constraints, self._domains(used), symbols, values)

    def verdict(self, constraints: list[Any]) -> str:
        """`verdict` of these constraints with the ranges of the variables they
        mention, asked now (not cached)."""
        return verdict([*self._domains(names_in(constraints)), *constraints])

    def _domains(self, used: set[str]) -> list[Any]:
        return [c for name in sorted(used & self.domains.keys()) for c in self.domains[name]]

    def present(self, constraints: list[Any]) -> Any:
        """Every value these constraints read has a value (each topic has published):
        true after the start, whatever state a transducer is in."""
        flags = [self.symbols[n] for n in sorted(names_in(constraints)) if n.startswith(PRESENT)]
        return z3.And(*flags) if flags else z3.BoolVal(True)

    @staticmethod
    def names_of(condition: Any) -> set[str]:
        """The variables and values a condition (`of_event`'s term) reads (two
        conditions that share none are independent)."""
        return {_value_name(n) for n in names_in([condition])}

    def free(self, key: str, kind: str, may_be_absent: bool = True) -> Term:
        """A value of its own, one per key (the same text means the same value),
        absent where its own presence flag is false."""
        if key not in self.symbols:
            self.symbols[key] = constant(key, kind)
        if not may_be_absent:
            return Term(self.symbols[key])
        flag = PRESENT + key
        if flag not in self.symbols:
            self.symbols[flag] = z3.Bool(flag)
        return Term(self.symbols[key], self.symbols[flag])

    def variable(self, name: str, vtype: ir.ValueType) -> Term:
        if name not in self.symbols:
            symbol = self.symbols[name] = constant(name, _sort_kind(vtype.kind))
            if vtype.ros in INTEGER_RANGES:
                least, most = INTEGER_RANGES[vtype.ros]
                self.domains[name] = [symbol >= least, symbol <= most]
        return self.free(name, "")

    def expr(self, node: ir.Expr) -> Term | Kleene:
        """A lowered expression as z3 computes it, with where it has a value."""
        match node:
            case ir.Number():
                kind = "int" if isinstance(literal(node.text), int) else "float"
                return Term(number(node.value, kind))
            case ir.Boolean():
                return Term(z3.BoolVal(node.value))
            case ir.String():
                return Term(z3.StringVal(node.value))
            case ir.Time():
                return Term(number(node.seconds, "float"))
            case ir.Ref():
                return self.name(node)
            case ir.Unary():
                operand = self.expr(node.operand)
                if node.op == "not":
                    return Term(z3.Not(as_bool(operand.value)), operand.present)
                return Term(negate(operand.value), operand.present)
            case ir.Binary():
                return self.binary(node)
            case ir.Call() if node.function in ELEMENTWISE:
                return self.call(node)
        # A function of the data: a value of its own, of its type's sort.
        return self.free(text(node), _sort_kind(node.type.kind))

    def call(self, node: ir.Call) -> Term:
        """A transformation of one value (`abs(V)`): exact where z3 computes it, else
        a value of its own (named by its text, which a witness prints); no value
        where the runtime has none."""
        arguments = [self.expr(a) for a in node.args]
        value = transform(node.function, arguments[0].value)
        if value is None:
            value = self.free(text(node), "float", may_be_absent=False).value
        present = z3.And(*(a.present for a in arguments))
        if is_float(value):
            undefined = undefined_at(value, [a.value for a in arguments])
            present = z3.And(present, z3.Not(undefined))
        return Term(value, z3.simplify(present))

    def name(self, ref: ir.Ref) -> Term:
        name = ref.name
        if ref.kind == "variable":
            return self.variable(name, ref.type)
        if ref.kind == "emitted":
            return self.free(f"event {name}", "bool", may_be_absent=False)
        decl = self.model.events.get(name)
        if decl is not None and decl.boolean:
            # An event holds or does not: never unknown (its unknown condition
            # does not hold), so `not E` holds where E's condition is unknown.
            return Term(self.of_event(name))
        return self.free(name, _sort_kind(ref.type.kind))  # a value event: its newest value

    def binary(self, node: ir.Binary) -> Term | Kleene:
        left, right = self.expr(node.left), self.expr(node.right)
        op = node.op
        if op in ("and", "or"):
            return kleene(op, left, right)
        if op in ("=~", "!~"):
            return self.free(text(node), "bool")
        try:
            return Term(apply(op, left.value, right.value), _both(left, right))
        except (z3.Z3Exception, TypeError, KeyError):
            kind = "bool" if op in ("=", "!=", *_ORDERS) else "float"
            return self.free(text(node), kind)


def text(node: ir.Expr) -> str:
    """An expression's text, the name of its free value: the same text, the same
    value (`mean(V)` in two events)."""
    match node:
        case ir.Number() | ir.Time():
            return node.text
        case ir.String():
            return repr(node.value)
        case ir.Boolean():
            return "true" if node.value else "false"
        case ir.Ref():
            return node.name
        case ir.Unary():
            return (
                f"{node.op} ({text(node.operand)})"
                if node.op == "not"
                else f"-({text(node.operand)})"
            )
        case ir.Binary():
            return f"({text(node.left)}) {node.op} ({text(node.right)})"
        case ir.Call():
            return f"{node.function}({', '.join(text(a) for a in node.args)})"
    return repr(node)


def _shape(node: ir.Expr, names: dict[str, str]) -> str:
    """An expression in prefix notation, each name it reads replaced by its
    canonical one in `names` (given in the order of first reading), by a loop
    (expressions nest deep). Leaves carry no names: their repr is their text."""
    out: list[str] = []
    stack = [node]
    while stack:
        item = stack.pop()
        if isinstance(item, ir.Ref):
            called = names.setdefault(item.name, f"n{len(names)}")
            out.append(f"ref {called} {item.kind} {item.type!r}")
        elif isinstance(item, ir.Unary):
            out.append(f"unary {item.op} {item.type!r}")
            stack.append(item.operand)
        elif isinstance(item, ir.Binary):
            out.append(f"binary {item.op} {item.type!r}")
            stack.extend((item.right, item.left))
        elif isinstance(item, ir.Call):
            out.append(f"call {item.function} {len(item.args)} {item.type!r}")
            stack.extend(reversed(item.args))
        else:
            out.append(repr(item))
    return " ".join(out)


def _refs(node: ir.Expr) -> list[ir.Ref]:
    """The names an expression reads, left to right, by a loop (expressions nest
    deep)."""
    found, stack = [], [node]
    while stack:
        item = stack.pop()
        if isinstance(item, ir.Ref):
            found.append(item)
        elif isinstance(item, ir.Unary):
            stack.append(item.operand)
        elif isinstance(item, ir.Binary):
            stack.extend((item.right, item.left))
        elif isinstance(item, ir.Call):
            stack.extend(reversed(item.args))
    return found


def _value_name(name: str) -> str:
    return name.removeprefix(PRESENT)


def _sort_kind(kind: str) -> str:
    """The z3 sort of a value of this kind: times and durations are seconds."""
    return kind if kind in ("bool", "int", "string") else "float"
