"""The compiled RMTLD3 formula: typed nested tuples (standard library only).

Each node is a NamedTuple whose first element is its tag, so a node is also the
plain tuple `("until", "<", 10, f, g)` the monitor, the reference evaluator and the
solvers read by position. Build nodes with the functions below; `to_lists` and
`from_lists` convert to and from JSON's nested lists without recursion (a formula
can nest 100,000 levels).

    formulas: prop const not and or until since cmp
    terms:    num dur add sub mul
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, NamedTuple

from rmvdsl.runtime.nesting import bottom_up
from rmvdsl.runtime.signal import plain

Time = int | Fraction


class Prop(NamedTuple):
    tag: str
    name: str


class Const(NamedTuple):
    tag: str
    value: bool


class Not(NamedTuple):
    tag: str
    operand: Formula


class And(NamedTuple):
    tag: str
    left: Formula
    right: Formula


class Or(NamedTuple):
    tag: str
    left: Formula
    right: Formula


class Until(NamedTuple):
    tag: str
    op: str  # "<" | "<=" | "="
    bound: Time
    left: Formula
    right: Formula


class Since(NamedTuple):
    tag: str
    op: str
    bound: Time | None  # None: no bound, the whole trace so far
    left: Formula
    right: Formula


class Cmp(NamedTuple):
    tag: str
    op: str  # "<" | "<=" | ">" | ">=" | "==" | "!="
    left: Term
    right: Term


class Num(NamedTuple):
    tag: str
    value: Time


class Dur(NamedTuple):
    tag: str
    window: Time
    body: Formula


class Add(NamedTuple):
    tag: str
    left: Term
    right: Term


class Sub(NamedTuple):
    tag: str
    left: Term
    right: Term


class Mul(NamedTuple):
    tag: str
    left: Term
    right: Term


Formula = Prop | Const | Not | And | Or | Until | Since | Cmp
Term = Num | Dur | Add | Sub | Mul
NODES: dict[str, Any] = {
    "prop": Prop, "const": Const, "not": Not, "and": And, "or": Or, "until": Until,
    "since": Since, "cmp": Cmp, "num": Num, "dur": Dur, "add": Add, "sub": Sub, "mul": Mul,
}  # fmt: skip
TRUE = Const("const", True)


def prop(name: str) -> Prop:
    return Prop("prop", name)


def const(value: bool) -> Const:
    return Const("const", value)


def not_(operand: Formula) -> Formula:
    return Not("not", operand)


def binary(tag: str, left: Any, right: Any) -> Any:
    """`and`, `or`, `add`, `sub` or `mul` of two nodes."""
    return NODES[tag](tag, left, right)


def temporal(tag: str, op: str, bound: Time | None, left: Formula, right: Formula) -> Formula:
    """`bound` None: a `since` over the whole trace so far (`until` has a bound)."""
    node: Formula = NODES[tag](tag, op, bound, left, right)
    return node


def cmp(op: str, left: Term, right: Term) -> Cmp:
    return Cmp("cmp", op, left, right)


def num(value: Time) -> Num:
    return Num("num", value)


def dur(window: Time, body: Formula) -> Dur:
    return Dur("dur", window, body)


def to_lists(node: Any) -> list[Any]:
    """The formula as nested JSON lists, numbers kept as they are."""
    done: dict[int, list[Any]] = {}
    stack: list[tuple[Any, bool]] = [(node, False)]
    while stack:
        current, expanded = stack.pop()
        children = [c for c in current[1:] if isinstance(c, tuple)]
        if not expanded:
            stack.append((current, True))
            stack.extend((child, False) for child in children)
            continue
        done[id(current)] = [done[id(c)] if isinstance(c, tuple) else c for c in current]
    return done[id(node)]


def from_lists(value: list[Any], number: Any = Fraction) -> Any:
    """The formula of `to_lists` back as typed nodes; `number` reads each number
    (JSON gives ints, floats or exact texts)."""
    done: dict[int, Any] = {}
    stack: list[tuple[list[Any], bool]] = [(value, False)]
    while stack:
        current, expanded = stack.pop()
        if not isinstance(current, list) or not current or current[0] not in NODES:
            raise ValueError(f"not a formula node: {str(current)[:60]}")
        children = [c for c in current[1:] if isinstance(c, list)]
        if not expanded:
            stack.append((current, True))
            stack.extend((child, False) for child in children)
            continue
        tag = current[0]
        parts = [done[id(c)] if isinstance(c, list) else c for c in current[1:]]
        index = 1 if tag in ("until", "since") else 0
        if tag in ("until", "since", "dur", "num") and index < len(parts):
            if parts[index] is not None:
                parts[index] = plain(number(parts[index]))
            elif tag != "since":  # only `since` may have no bound
                raise ValueError(f"`{tag}` needs a bound: {str(current)[:60]}")
        try:
            done[id(current)] = NODES[tag](tag, *parts)
        except TypeError:
            raise ValueError(f"malformed `{tag}` node: {str(current)[:60]}") from None
    return done[id(value)]


class _Scaled(NamedTuple):
    node: Any  # the subformula or term with its times scaled
    constant: bool  # a term without a duration in it: a product's constant factor


def scaled(formula: Any, factor: int) -> Any:
    """The formula with every time in it multiplied by `factor`: the bounds, the
    windows of durations and the numbers of terms, except a product's constant
    factor (as `rmvdsl.logic.compile` reads `2 * duration(...)`). Its verdicts over
    times multiplied by `factor` are the formula's: the runtime feeds its monitors
    integer nanoseconds (exact, and cheaper than fractions of a second)."""

    def times(value: Any) -> Any:
        value = value * factor
        return value.numerator if isinstance(value, Fraction) and value.denominator == 1 else value

    def rebuild(node: Any, fields: list[Any]) -> _Scaled:
        tag = node[0]
        parts = [f.node if isinstance(f, _Scaled) else f for f in fields]
        constant = all(f.constant for f in fields if isinstance(f, _Scaled))
        if tag == "num":
            return _Scaled(Num(tag, times(node[1])), True)
        if tag == "dur":
            return _Scaled(Dur(tag, times(node[1]), parts[1]), False)
        if tag in ("until", "since") and node[2] is not None:
            parts[1] = times(node[2])
        elif tag == "mul":
            left, right = fields
            if left.constant:  # the left of two constants is the factor
                parts[0] = node[1]
            elif right.constant:
                parts[1] = node[2]
        return _Scaled(NODES[tag](tag, *parts), constant)

    result: _Scaled = bottom_up(formula, rebuild)
    return result.node
