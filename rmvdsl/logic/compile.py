"""From the formula tree to the runtime's typed nested tuples (runtime/formulas.py).

Times become numbers in the trace's unit (seconds unless said otherwise): `10s` is
10, `100ms` is 1/10, and a bare number is taken in the given default unit, wherever
it stands for a time: a bound, a window, a side of a comparison of durations, a
summand. The one bare number that is not a time is the constant factor of a
product (`2 * duration[10s](p)`): it scales, so it keeps its value.
`eventually`, `always`, `once`, `historically`, `->` and `<->` are rewritten with
until, since, not, and, or, as docs/semantics.md defines them.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from rmvdsl.grammar import formula as fm
from rmvdsl.grammar.formula import TIME_UNITS
from rmvdsl.runtime import formulas as f


class CompileError(Exception):
    def __init__(self, message: str, node: Any) -> None:
        super().__init__(message)
        self.node = node


def compile_formula(
    formula: fm.Formula | fm.Term, unit: Fraction = Fraction(1), default_unit: str | None = "s"
) -> Any:
    """A formula (or a term) as runtime tuples. `unit`: one trace time unit in
    seconds; `default_unit`: the unit of bare numbers."""
    compiler = _Compiler(unit, default_unit)
    if isinstance(formula, fm.Term):
        return compiler.term(formula)
    return compiler.formula(formula)


class _Compiler:
    def __init__(self, unit: Fraction, default_unit: str | None) -> None:
        self.unit = unit
        self.default_unit = default_unit

    def time(self, value: fm.TimeValue, node: Any) -> Fraction:
        seconds = value.seconds(self.default_unit)
        if seconds is None:
            raise CompileError(f"the time `{value.text}` has no unit", node)
        return seconds / self.unit

    def formula(self, node: fm.Formula) -> Any:
        match node:
            case fm.Prop():
                return f.prop(node.name)
            case fm.Const():
                return f.const(node.value)
            case fm.Not():
                operand = self.formula(node.operand)
                # not not f is f, in three values too: a chain of 40,000 stays shallow
                return operand[1] if operand[0] == "not" else f.not_(operand)
            case fm.Binary() if node.op in ("and", "or"):
                return _balanced(node.op, [self.formula(o) for o in _chain(node)])
            case fm.Binary():
                left, right = self.formula(node.left), self.formula(node.right)
                implies = f.binary("or", f.not_(left), right)
                if node.op == "->":
                    return implies
                return f.binary("and", implies, f.binary("or", f.not_(right), left))
            case fm.Temporal():
                return self.temporal(node)
            case fm.Compare():
                return f.cmp(node.op, self.term(node.left), self.term(node.right))
        raise CompileError(f"not a formula: {node!r}", node)

    def temporal(self, node: fm.Temporal) -> Any:
        bound: Any = None  # a past operator with no bound: the whole trace so far
        op = "<="
        if node.bound is None and node.op in fm.FUTURE:
            raise CompileError(f"`{node.op}` needs a time bound", node)
        if node.bound is not None:
            bound = self.time(node.bound.value, node)
            if bound < 0:
                raise CompileError("a time bound must not be negative", node)
            op = node.bound.op
        body = self.formula(node.right)
        true = f.TRUE
        match node.op:
            case "until" | "since":
                assert node.left is not None
                return f.temporal(node.op, op, bound, self.formula(node.left), body)
            case "eventually":
                return f.temporal("until", op, bound, true, body)
            case "once":
                return f.temporal("since", op, bound, true, body)
            case "always":
                return f.not_(f.temporal("until", op, bound, true, f.not_(body)))
            case "historically":
                return f.not_(f.temporal("since", op, bound, true, f.not_(body)))
        raise CompileError(f"unknown temporal operator {node.op}", node)

    def term(self, node: fm.Term, scalar: bool = False) -> Any:
        """`scalar`: the term is the constant factor of a product, not a time."""
        match node:
            case fm.Number():
                if node.time is not None:
                    return f.num(self.time(node.time, node) * (1 if node.value >= 0 else -1))
                if scalar or self.default_unit is None:
                    return f.num(node.value)
                return f.num(node.value * TIME_UNITS[self.default_unit] / self.unit)
            case fm.Duration():
                return f.dur(self.time(node.window, node), self.formula(node.body))
            case fm.Arith() if node.op == "+":
                # a sum associates: its constants folded, the rest as a shallow tree
                terms = [self.term(t) for t in _chain(node)]
                constant = sum((t[1] for t in terms if t[0] == "num"), Fraction(0))
                rest = [t for t in terms if t[0] != "num"]
                if not rest or constant:
                    rest.append(f.num(constant))
                return _balanced("add", rest)
            case fm.Arith():
                kind = {"+": "add", "-": "sub", "*": "mul"}[node.op]
                # In a product one factor scales the other: a constant beside a
                # duration, or the left of two constants (`2 * 3` is 6 time units).
                product = kind == "mul"
                left_scales = product and _constant(node.left)
                right_scales = product and _constant(node.right) and not left_scales
                left = self.term(node.left, left_scales)
                right = self.term(node.right, right_scales)
                if kind == "mul" and left[0] != "num" and right[0] != "num":
                    raise CompileError(
                        "a product of two durations is not linear: one side must be a constant",
                        node,
                    )
                return f.binary(kind, left, right)
        raise CompileError(f"not a term: {node!r}", node)


def _chain(node: Any) -> list[Any]:
    """The operands of `a and b and c ...` or `a + b + c ...` (one operator, any
    grouping), in order."""
    out: list[Any] = []
    stack: list[Any] = [node]
    while stack:
        current = stack.pop()
        if type(current) is type(node) and current.op == node.op:
            stack += [current.right, current.left]
        else:
            out.append(current)
    return out


def _balanced(op: str, operands: list[Any]) -> Any:
    """`and`/`or` of the operands as a tree of logarithmic depth (they associate):
    the monitor and the solver then never recurse deeper than about 20 levels."""
    while len(operands) > 1:
        paired = [f.binary(op, a, b) for a, b in zip(operands[::2], operands[1::2], strict=False)]
        operands = paired + operands[len(paired) * 2 :]
    return operands[0]


def _constant(term: fm.Term) -> bool:
    """A term with no duration in it: as a factor of a product it is a plain number."""
    return not any(isinstance(n, fm.Duration) for n in fm.walk(term))
