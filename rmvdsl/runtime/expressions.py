"""Expressions as InfluxQL evaluates them (docs/runtime.md, "Values" and
"Operators"): compiled once to closures, with absent values read as SQL does
(docs/semantics.md, "Absent values": Kleene's `and` and `or`)."""

from __future__ import annotations

import operator
import re
from collections.abc import Callable
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime import values
from rmvdsl.runtime.functions import ELEMENTWISE, elementwise
from rmvdsl.runtime.series import MISSING


def evaluate(expr: ir.Expr, lookup: Callable[[str], Any]) -> Any:
    """The value of an expression whose only calls are transformations of one value
    (`abs`, `round`, `sqrt`...), or MISSING when a name it
    reads has no value. MISSING is SQL's null, read as "unknown" (docs/semantics.md,
    "Absent values"): arithmetic and comparisons with it are MISSING, `not MISSING`
    is MISSING, and `and`/`or` are Kleene's (`false and MISSING` is false, `true or
    MISSING` is true). A condition holds only where it is `True`."""
    return compiled(expr)(lookup)


Evaluator = Callable[[Callable[[str], Any]], Any]
CACHE_LIMIT = 4096  # expressions (and regular expressions) kept compiled
_COMPILED: dict[int, tuple[ir.Expr, Evaluator]] = {}


def compiled(expr: ir.Expr) -> Evaluator:
    """`evaluate` for one expression, as a closure built once: the runtime evaluates
    a condition at every message."""
    found = _COMPILED.get(id(expr))
    if found is None or found[0] is not expr:
        if len(_COMPILED) >= CACHE_LIMIT:
            _COMPILED.clear()  # a long-lived process (the editor) checks spec after spec
        found = _COMPILED[id(expr)] = (expr, _compile(expr))
    return found[1]


def _compile(expr: ir.Expr) -> Evaluator:
    match expr:
        case ir.Number():
            return _constant(number_value(expr))
        case ir.String() | ir.Boolean():
            return _constant(expr.value)
        case ir.Time():
            return _constant(expr.seconds)
        case ir.Ref():
            name = expr.name
            return lambda lookup: lookup(name)
        case ir.Unary():
            operand, op = _compile(expr.operand), expr.op
            return lambda lookup: unary(op, operand(lookup))
        case ir.Binary() if expr.op in ("and", "or"):
            return _connective(expr.op == "or", [_compile(e) for e in _operands(expr)])
        case ir.Binary():
            return _compile_binary(expr, _compile(expr.left), _compile(expr.right))
        case ir.Call() if expr.function in ELEMENTWISE:
            return _compile_call(expr)
    raise ValueError(f"cannot evaluate {type(expr).__name__} here")


def _compile_call(call: ir.Call) -> Evaluator:
    """A transformation of the values read at this instant (`abs(V) > 3`): the
    checker lets a condition apply no other function (RMV321)."""
    name, operand = call.function, _compile(call.args[0])
    if len(call.args) == 1:
        return lambda lookup: elementwise(name, operand(lookup), None)
    second = _compile(call.args[1])  # a constant, or atan2's x

    def apply(lookup: Callable[[str], Any]) -> Any:
        other = second(lookup)
        return MISSING if other is MISSING else elementwise(name, operand(lookup), other)

    return apply


def _constant(value: Any) -> Evaluator:
    return lambda lookup: value


def _compile_binary(expr: ir.Binary, left: Evaluator, right: Evaluator) -> Evaluator:
    op = expr.op
    if op in _ORDERING:
        compare = _ORDERING[op]
        if isinstance(expr.left, ir.Ref) and isinstance(expr.right, ir.Number):
            constant = number_value(expr.right)
            if type(constant) in (int, float):
                return _name_against(op, expr.left.name, constant)

        def ordering(lookup: Callable[[str], Any]) -> Any:
            a, b = left(lookup), right(lookup)
            kinds = type(a), type(b)
            if kinds == (float, float) or kinds == (int, int):
                return compare(a, b)  # the common case: no conversion to decide
            if kinds == (float, int) or kinds == (int, float):
                return compare(float(a), float(b))  # as values.compare: mixed, as floats
            if a is MISSING or b is MISSING:
                return MISSING
            return values.compare(op, a, b)

        return ordering
    return lambda lookup: binary(expr, left(lookup), lambda: right(lookup))


def _name_against(op: str, name: str, constant: int | float) -> Evaluator:
    """`name op constant` (`Velocity > 0.1`, most conditions), as `ordering` does
    it, in one call: a value of the constant's type compares as it is, a number of
    the other type as floats."""
    compare, same = _ORDERING[op], type(constant)
    other, as_float = (float if same is int else int), float(constant)

    def against(lookup: Callable[[str], Any]) -> Any:
        value = lookup(name)
        kind = type(value)
        if kind is same:
            return compare(value, constant)
        if kind is other:
            return compare(float(value), as_float)
        if value is MISSING:
            return MISSING
        return values.compare(op, value, constant)

    return against


_ORDERING: dict[str, Callable[[Any, Any], bool]] = {
    "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge,
}  # fmt: skip


def unary(op: str, operand: Any) -> Any:
    if operand is MISSING:
        return MISSING
    if op == "not":
        return operand is False
    return values.negate(operand)


def _operands(expr: ir.Binary) -> list[ir.Expr]:
    """The operands of a chain of one connective (`a and b and c`, grouped either
    way), in order: Kleene's `and` and `or` are associative, and both groupings
    evaluate the operands in order up to the first that decides."""
    operands: list[ir.Expr] = []
    stack: list[ir.Expr] = [expr]
    while stack:
        node = stack.pop()
        if isinstance(node, ir.Binary) and node.op == expr.op:
            stack += [node.right, node.left]
        else:
            operands.append(node)
    return operands


def _connective(deciding: bool, operands: list[Evaluator]) -> Evaluator:
    """`_kleene` compiled for the runtime's hot path (a condition at every message):
    no closure made per evaluation, one call for a chain."""
    if len(operands) == 2:
        left, right = operands

        def connective(lookup: Callable[[str], Any]) -> Any:
            a = left(lookup)
            return deciding if a is deciding else _settled(deciding, a, right(lookup))

        return connective
    other = not deciding

    def chain(lookup: Callable[[str], Any]) -> Any:
        unknown = False
        for operand in operands:
            value = operand(lookup)
            if value is deciding:
                return deciding
            if value is not other:
                unknown = True
        return MISSING if unknown else other

    return chain


def kleene_and(left: Any, right_of: Callable[[], Any]) -> Any:
    """`and` over true, false and MISSING (unknown): false wins, then unknown."""
    return _kleene(False, left, right_of)


def kleene_or(left: Any, right_of: Callable[[], Any]) -> Any:
    """`or` over true, false and MISSING (unknown): true wins, then unknown."""
    return _kleene(True, left, right_of)


def _kleene(deciding: bool, left: Any, right_of: Callable[[], Any]) -> Any:
    """A connective whose `deciding` operand decides it whatever the other is (the
    right one is not evaluated then)."""
    return deciding if left is deciding else _settled(deciding, left, right_of())


def _settled(deciding: bool, left: Any, right: Any) -> Any:
    """The connective once the left side has not decided it: the right one may; two
    of the other value give that value; anything else is unknown."""
    if right is deciding:
        return deciding
    other = not deciding
    return other if left is other and right is other else MISSING


def number_value(node: ir.Number) -> int | float:
    return values.literal(node.text)


def binary(expr: ir.Binary, left: Any, right_of: Callable[[], Any]) -> Any:
    op = expr.op
    if op == "and":
        return kleene_and(left, right_of)
    if op == "or":
        return kleene_or(left, right_of)
    right = right_of()
    if left is MISSING or right is MISSING:
        return MISSING
    if op in ("=~", "!~"):
        found = _regex(right).search(left) is not None
        return found if op == "=~" else not found
    return values.binary(op, left, right)


_REGEXES: dict[str, Any] = {}


def _regex(text: str) -> Any:
    found = _REGEXES.get(text)
    if found is None:
        if len(_REGEXES) >= CACHE_LIMIT:
            _REGEXES.clear()
        found = _REGEXES[text] = re.compile(text)
    return found
