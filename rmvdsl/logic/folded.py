"""Times and booleans of the bounded encoding: a time as a base point plus a constant,
and z3 booleans folded with Python's so that what is decided statically never
reaches z3."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import z3

from rmvdsl.logic.terms import conjunction, disjunction, negation

# A time: (base, offset). base 0 is time 0, base i >= 1 the change time t_i,
# base -1 the evaluation time, base -2 - j the j-th crossing point (below).
Time = tuple[int, Fraction]
ZERO: Time = (0, Fraction(0))
EVAL = -1

Bool = Any  # a z3 BoolRef, or a Python bool once folded


def fold(items: tuple[Bool, ...], absorbing: bool, combine: Any) -> Bool:
    """`and` (absorbing False) or `or` (absorbing True), folding Python bools so
    that what is decided statically never reaches z3."""
    rest = []
    for item in items:
        if item is absorbing:
            return absorbing
        if item is not (not absorbing):
            rest.append(item)
    if not rest:
        return not absorbing
    return rest[0] if len(rest) == 1 else combine(rest)


def and_(*items: Bool) -> Bool:
    return fold(items, False, conjunction)


def or_(*items: Bool) -> Bool:
    return fold(items, True, disjunction)


def not_(item: Bool) -> Bool:
    return (not item) if isinstance(item, bool) else negation(item)


def as_z3(item: Bool) -> Any:
    return z3.BoolVal(item) if isinstance(item, bool) else item
