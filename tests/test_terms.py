"""`compare` and `arithmetic` of interval-valued terms: the reference evaluator and
the monitor share them, so the differential test between those two cannot catch a
mistake here. Hand-written tables, and every small case against brute force."""

from __future__ import annotations

import itertools
import operator
from fractions import Fraction

import pytest

from rmvdsl.runtime.rmtld3 import FALSE, TRUE, UNKNOWN, arithmetic, compare

F = Fraction


@pytest.mark.parametrize(
    ("op", "left", "right", "expected"),
    [
        ("<", (1, 2), (3, 4), TRUE),
        ("<", (3, 3), (3, 3), FALSE),
        ("<", (1, 2), (2, 3), UNKNOWN),  # 2 < 2 is false, 1 < 3 true
        ("<", (4, 5), (1, 2), FALSE),
        ("<=", (3, 3), (3, 3), TRUE),
        ("<=", (1, 3), (2, 2), UNKNOWN),
        (">", (5, 6), (1, 4), TRUE),
        (">=", (1, 2), (2, 3), UNKNOWN),
        (">=", (2, 2), (1, 2), TRUE),
        ("==", (2, 2), (2, 2), TRUE),
        ("==", (1, 2), (3, 4), FALSE),
        ("==", (1, 2), (1, 2), UNKNOWN),
        ("!=", (2, 2), (2, 2), FALSE),
        ("!=", (1, 2), (3, 4), TRUE),
        ("!=", (1, 3), (2, 2), UNKNOWN),
    ],
)
def test_compare_by_hand(op, left, right, expected):
    assert compare(op, left, right) == expected


@pytest.mark.parametrize(
    ("kind", "left", "right", "expected"),
    [
        ("add", (1, 2), (10, 20), (11, 22)),
        ("sub", (1, 2), (10, 20), (-19, -8)),
        ("mul", (-1, 2), (3, 4), (-4, 8)),
        ("mul", (-2, -1), (-3, 4), (-8, 6)),
        ("mul", (F(1, 2), F(1, 2)), (4, 4), (2, 2)),
    ],
)
def test_arithmetic_by_hand(kind, left, right, expected):
    assert arithmetic(kind, left, right) == expected


_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge,
        "==": operator.eq, "!=": operator.ne}  # fmt: skip
_INTERVALS = [(F(a), F(b)) for a in range(-2, 3) for b in range(-2, 3) if a <= b]


def _points(interval: tuple[Fraction, Fraction], other=()) -> list[Fraction]:
    """A grid over the interval, with the other interval's ends where they fall in
    it (where `==` can hold)."""
    low, high = interval
    grid = [low + (high - low) * F(k, 4) for k in range(5)]
    return grid + [v for v in other if low <= v <= high]


def test_compare_is_the_three_valued_truth_over_all_values():
    for (name, op), left, right in itertools.product(_OPS.items(), _INTERVALS, _INTERVALS):
        truths = {op(x, y) for x in _points(left, right) for y in _points(right, left)}
        expected = TRUE if truths == {True} else FALSE if truths == {False} else UNKNOWN
        assert compare(name, left, right) == expected, (name, left, right)


def test_arithmetic_is_the_range_of_all_values():
    apply = {"add": operator.add, "sub": operator.sub, "mul": operator.mul}
    for (kind, op), left, right in itertools.product(apply.items(), _INTERVALS, _INTERVALS):
        values = [op(x, y) for x in _points(left) for y in _points(right)]
        assert arithmetic(kind, left, right) == (min(values), max(values)), (kind, left, right)
