"""What the operators of event expressions compute: InfluxQL's semantics, exactly.

This module uses the Python standard library only. It is the one definition of an
operator's meaning; the solver model of `rmv check` (rmvdsl/check/operators.py) is
tested against it value by value, and so will every target be (docs/runtime.md).

Values are `bool`, `int` (64-bit two's complement, as InfluxDB stores integers),
`float` (IEEE 754 double) and `str`. As in InfluxDB 1.x:

- `+ - *` on two integers wrap around at 64 bits; with a float on either side both
  are floats (the integer rounded to the nearest double).
- `/` always divides as floats: `5 / 8` is 0.625. Dividing by zero gives 0.
- `%` on two integers is the remainder with the sign of the dividend (Go's `%`), and 0
  for a zero divisor; on floats it is C's `fmod` (NaN for a zero divisor).
- `& | ^` take integers (or two bools).
- Comparisons of an integer with a float compare as floats; any comparison with NaN
  is false except `!=`.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction

INT_BITS = 64
INT_MIN = -(2 ** (INT_BITS - 1))
INT_MAX = 2 ** (INT_BITS - 1) - 1
_MODULUS = 2**INT_BITS

# The range of each ROS integer type (char is uint8 in ROS 1 and ROS 2 alike).
INTEGER_RANGES: dict[str, tuple[int, int]] = {
    "int8": (-(2**7), 2**7 - 1),
    "uint8": (0, 2**8 - 1),
    "byte": (0, 2**8 - 1),
    "char": (0, 2**8 - 1),
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (INT_MIN, INT_MAX),
    # InfluxDB's integers are signed: a uint64 above INT_MAX wraps, as `wrap` says.
    "uint64": (INT_MIN, INT_MAX),
}


class OperatorError(TypeError):
    """Operands an operator does not take (the checker's types stage prevents them)."""


def literal(text: str) -> int | float:
    """A number written in a spec: an integer when it is digits only (`5`), else the
    double nearest to it (`5.0`, `0.8`, `1e3`). A unit after it is not read."""
    match = _LITERAL.match(text)
    number = match.group() if match else "0"
    if number.lstrip("-").isdigit() and len(number) <= 4000:  # int()'s own limit is 4300
        return int(number)
    return float(number)


_LITERAL = re.compile(r"-?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")


def wrap(value: int) -> int:
    """An integer as InfluxDB's int64 holds it."""
    return (value - INT_MIN) % _MODULUS + INT_MIN


def is_int(value: object) -> bool:
    return type(value) is int


def _number(value: object) -> bool:
    return type(value) in (int, float)


def remainder(left: int, right: int) -> int:
    """Go's `%` on int64: truncated division, the sign of the dividend."""
    if right == 0:
        return 0
    result = abs(left) % abs(right)
    return wrap(-result if left < 0 else result)


def fmod(left: float, right: float) -> float:
    if right == 0 or math.isinf(left) or math.isnan(left) or math.isnan(right):
        return math.nan
    return math.fmod(left, right)


def arithmetic(op: str, left: object, right: object) -> int | float:
    """`+ - * / %` on two numbers."""
    if not (_number(left) and _number(right)):
        raise OperatorError(f"`{op}` needs numbers, got {left!r} and {right!r}")
    if op == "/":
        divisor = float(right)  # type: ignore[arg-type]
        return 0.0 if divisor == 0 else float(left) / divisor  # type: ignore[arg-type]
    if is_int(left) and is_int(right):
        a, b = int(left), int(right)  # type: ignore[call-overload]
        if op == "+":
            return wrap(a + b)
        if op == "-":
            return wrap(a - b)
        if op == "*":
            return wrap(a * b)
        if op == "%":
            return remainder(a, b)
    else:
        x, y = float(left), float(right)  # type: ignore[arg-type]
        if op == "+":
            return x + y
        if op == "-":
            return x - y
        if op == "*":
            return x * y
        if op == "%":
            return fmod(x, y)
    raise OperatorError(f"unknown operator `{op}`")


def bitwise(op: str, left: object, right: object) -> int | bool:
    if type(left) is bool and type(right) is bool:
        return {"&": left and right, "|": left or right, "^": left != right}[op]
    if not (is_int(left) and is_int(right)):
        raise OperatorError(f"`{op}` needs integers, got {left!r} and {right!r}")
    a, b = int(left), int(right)  # type: ignore[call-overload]
    if op == "&":
        return a & b
    if op == "|":
        return a | b
    if op == "^":
        return a ^ b
    raise OperatorError(f"unknown operator `{op}`")


def compare(op: str, left: object, right: object) -> bool:
    """`= != < <= > >=`; numbers of mixed kinds compare as floats."""
    if _number(left) and _number(right) and not (is_int(left) and is_int(right)):
        left, right = float(left), float(right)  # type: ignore[arg-type]
    elif type(left) is not type(right):
        return op == "!="
    if op == "=":
        return bool(left == right)
    if op == "!=":
        return bool(left != right)
    try:
        if op == "<":
            return bool(left < right)  # type: ignore[operator]
        if op == "<=":
            return bool(left <= right)  # type: ignore[operator]
        if op == ">":
            return bool(left > right)  # type: ignore[operator]
        if op == ">=":
            return bool(left >= right)  # type: ignore[operator]
    except TypeError as exc:
        raise OperatorError(str(exc)) from exc
    raise OperatorError(f"unknown comparison `{op}`")


def negate(value: object) -> int | float:
    if is_int(value):
        return wrap(-int(value))  # type: ignore[call-overload]
    if type(value) is float:
        return -value
    raise OperatorError(f"`-` needs a number, got {value!r}")


def binary(op: str, left: object, right: object) -> object:
    """Any binary operator but `and`/`or` (which the evaluator short-circuits) and
    the regular-expression matches."""
    if op in ("+", "-", "*", "/", "%"):
        return arithmetic(op, left, right)
    if op in ("&", "|", "^"):
        return bitwise(op, left, right)
    return compare(op, left, right)


def exact_text(value: Fraction) -> str:
    """A decimal where one is exact, else the quotient (`1/3`): reads back equal."""
    text = exact_decimal(value)
    return text if text is not None else str(value)


def exact_decimal(value: Fraction) -> str | None:
    """The exact decimal text of a fraction whose expansion ends (`0.1`, `-2.5`,
    `86400`), or None (`1/3`). rmvdsl.lang.numbers and the resolved spec's JSON both
    print numbers through it."""
    denominator = value.denominator
    if denominator == 1:
        return str(value.numerator)
    found = _PLACES.get(denominator)
    if found is None:
        digits = _places(denominator)
        # 1/denominator = factor/10^digits exactly where the expansion ends
        found = (digits, 10**digits // denominator if digits > 0 else 0)
        if len(_PLACES) < 4096:  # the few denominators times have (ns: divisors of 10^9)
            _PLACES[denominator] = found
    digits, factor = found
    if digits < 0:
        return None
    numerator = value.numerator
    text = str(abs(numerator) * factor).zfill(digits + 1)
    return f"{'-' if numerator < 0 else ''}{text[:-digits]}.{text[-digits:]}"


# denominator -> (decimal places, 10^places / denominator); places -1: none end
_PLACES: dict[int, tuple[int, int]] = {}


def _places(denominator: int) -> int:
    """The decimal places 1/denominator needs, or -1 where they never end."""
    twos = fives = 0
    while denominator % 2 == 0:
        denominator //= 2
        twos += 1
    while denominator % 5 == 0:
        denominator //= 5
        fives += 1
    return max(twos, fives) if denominator == 1 else -1


UNSET = object()  # the value of a name not read yet: the same as no other value


def same_value(old: object, new: object) -> bool:
    """Whether every expression reads `new` exactly as `old` (so a condition of
    values that are all the same is not evaluated again): the same type and value,
    and for a float zero the same sign (atan2 tells -0.0 from 0.0)."""
    if old is new:
        return True
    if type(old) is not type(new) or old != new:
        return False
    if type(new) is not float or new != 0.0:
        return True
    return math.copysign(1.0, old) == math.copysign(1.0, new)  # type: ignore[arg-type]
