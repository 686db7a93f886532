"""The runtime's operators as z3 terms: every operator means what
`rmvdsl.runtime.values` computes (InfluxQL's semantics). Integers are 64-bit
bit-vectors (wrapping `+ - *`, Go's `%`, bitwise operators), floats are IEEE
doubles (z3's floating-point theory: rounding, NaN and infinities included), `/`
divides as floats and gives 0 for a zero divisor. tests/test_soundness.py holds
each to the runtime, value by value.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import z3

from rmvdsl.runtime.values import INT_BITS

FLOAT = z3.Float64()
ROUNDING = z3.RNE()  # IEEE's default, and Go's


def constant(name: str, kind: str) -> Any:
    if kind == "bool":
        return z3.Bool(name)
    if kind == "string":
        return z3.String(name)
    if kind == "int":
        return z3.BitVec(name, INT_BITS)
    return z3.FP(name, FLOAT)  # floats, times and durations (seconds)


def number(value: Fraction, kind: str) -> Any:
    """A constant: an integer literal as a 64-bit integer, anything else as the
    double nearest to it (as InfluxQL parses it)."""
    if kind == "int" and value.denominator == 1 and -(2**63) <= value < 2**63:
        return z3.BitVecVal(int(value), INT_BITS)
    return z3.FPVal(float(value), FLOAT)


def is_int(value: Any) -> bool:
    return z3.is_bv(value)


def is_float(value: Any) -> bool:
    return z3.is_fp(value)


def to_float(value: Any) -> Any:
    if is_float(value):
        return value
    if z3.is_bool(value):
        value = z3.If(value, z3.BitVecVal(1, INT_BITS), z3.BitVecVal(0, INT_BITS))
    return z3.fpSignedToFP(ROUNDING, value, FLOAT)


def as_bool(value: Any) -> Any:
    if z3.is_bool(value):
        return value
    if is_float(value):
        return z3.Not(z3.fpIsZero(value))
    return value != 0


def negate(value: Any) -> Any:
    if is_float(value):
        return z3.fpNeg(value)
    if is_int(value):
        return -value
    raise TypeError("`-` needs a number")


def apply(op: str, left: Any, right: Any) -> Any:
    """`op` on two z3 values, as `rmvdsl.runtime.values.binary` computes it."""
    if op in ("&", "|", "^"):
        if not (is_int(left) and is_int(right)):
            raise TypeError(f"`{op}` needs integers")
        return {"&": left & right, "|": left | right, "^": left ^ right}[op]
    if z3.is_string(left) or z3.is_string(right):
        if op not in ("=", "!="):
            raise TypeError("strings are only compared for equality")
        return left == right if op == "=" else left != right
    if z3.is_bool(left) and z3.is_bool(right) and op in ("=", "!="):
        return left == right if op == "=" else left != right
    if op == "/":
        return _divide(to_float(left), to_float(right))
    if is_int(left) and is_int(right):
        return _integers(op, left, right)
    return _floats(op, to_float(left), to_float(right))


def _divide(left: Any, right: Any) -> Any:
    return z3.If(z3.fpIsZero(right), z3.FPVal(0.0, FLOAT), z3.fpDiv(ROUNDING, left, right))


def _integers(op: str, left: Any, right: Any) -> Any:
    zero = z3.BitVecVal(0, INT_BITS)
    return {
        "+": lambda: left + right,
        "-": lambda: left - right,
        "*": lambda: left * right,
        "%": lambda: z3.If(right == zero, zero, z3.SRem(left, right)),
        "=": lambda: left == right,
        "!=": lambda: left != right,
        "<": lambda: left < right,  # signed, as z3py's operators on bit-vectors are
        "<=": lambda: left <= right,
        ">": lambda: left > right,
        ">=": lambda: left >= right,
    }[op]()


def _floats(op: str, left: Any, right: Any) -> Any:
    return {
        "+": lambda: z3.fpAdd(ROUNDING, left, right),
        "-": lambda: z3.fpSub(ROUNDING, left, right),
        "*": lambda: z3.fpMul(ROUNDING, left, right),
        "%": lambda: _fmod(left, right),
        "=": lambda: z3.fpEQ(left, right),
        "!=": lambda: z3.Not(z3.fpEQ(left, right)),
        "<": lambda: z3.fpLT(left, right),
        "<=": lambda: z3.fpLEQ(left, right),
        ">": lambda: z3.fpGT(left, right),
        ">=": lambda: z3.fpGEQ(left, right),
    }[op]()


def _fmod(left: Any, right: Any) -> Any:
    """C's fmod from IEEE's remainder: the same value moved by |right| to the
    dividend's sign (exact: fmod's result is a double)."""
    rem = z3.fpRem(left, right)
    size = z3.fpAbs(right)
    moved = z3.If(
        z3.And(z3.fpIsPositive(left), z3.fpIsNegative(rem), z3.Not(z3.fpIsZero(rem))),
        z3.fpAdd(ROUNDING, rem, size),
        z3.If(
            z3.And(z3.fpIsNegative(left), z3.fpIsPositive(rem), z3.Not(z3.fpIsZero(rem))),
            z3.fpSub(ROUNDING, rem, size),
            rem,
        ),
    )
    nan = z3.fpNaN(FLOAT)
    return z3.If(z3.Or(z3.fpIsZero(right), z3.fpIsInf(left)), nan, moved)


# Transformations z3's floating-point theory computes exactly: IEEE's roundings and
# square root are correctly rounded, as Go's math and Python's math module are.
_ROUNDINGS = {"ceil": z3.RTP(), "floor": z3.RTN(), "round": z3.RNA()}


def transform(name: str, value: Any) -> Any | None:
    """`name(value)` as `rmvdsl.runtime.functions.elementwise` computes it before it
    reads a NaN as absent, or None where z3 has no exact model (`sin`, `pow`)."""
    if name == "abs":
        if is_int(value):
            return z3.If(value < 0, -value, value)  # -INT_MIN wraps to itself
        return z3.fpAbs(to_float(value))
    if name in _ROUNDINGS:
        return value if is_int(value) else z3.fpRoundToIntegral(_ROUNDINGS[name], value)
    if name == "sqrt":
        return z3.fpSqrt(ROUNDING, to_float(value))
    return None


def undefined_at(result: Any, arguments: list[Any]) -> Any:
    """Where a transformation's float result is no value (the runtime's MISSING):
    NaN, or infinite from finite arguments (Python's math raises there: `log(0)`,
    `exp(1000)`)."""
    finite = [z3.Not(z3.Or(z3.fpIsInf(a), z3.fpIsNaN(a))) for a in map(to_float, arguments)]
    return z3.Or(z3.fpIsNaN(result), z3.And(z3.fpIsInf(result), *finite))
