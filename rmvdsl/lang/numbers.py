"""Numbers written by people or by other tools: read exactly, within a range, and
printed back exactly.

Every number rmvdsl reads — in a spec, a formula, a trace, a command-line time — is
read by `exact`, which refuses, before any exact conversion, what would take
unbounded time or memory to build (`1e99999999` is 10^99999999 as a fraction) or
overflow a double when printed: at most `MAX_DIGITS` digits, and a magnitude below
10^MAX_MAGNITUDE (and zero or above 10^-MAX_MAGNITUDE). docs/language.md says so.
"""

from __future__ import annotations

import re
from decimal import Decimal, localcontext
from fractions import Fraction

from rmvdsl.runtime.values import exact_decimal
from rmvdsl.runtime.wording import counted

MAX_DIGITS = 100
MAX_MAGNITUDE = 300  # 10^300: doubles reach 1.8 x 10^308
RANGE_TEXT = f"at most {counted(MAX_DIGITS, 'digit')}, and a magnitude below 10^{MAX_MAGNITUDE}"

_NUMBER = re.compile(r"^\s*([+-]?)(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?\s*$")


class NumberError(ValueError):
    """Not a number, or one outside the range rmvdsl reads."""


def exact(text: str) -> Fraction:
    """The exact value of a decimal number (`12`, `-0.5`, `1.5e-3`)."""
    match = _NUMBER.match(text)
    if match is None or not (match.group(2) or match.group(3)):
        raise NumberError(f"`{_short(text)}` is not a number")
    sign, whole, fraction, exponent_text = match.groups()
    fraction = fraction or ""
    digits = (whole + fraction).lstrip("0")
    if len(digits) > MAX_DIGITS:
        raise NumberError(
            f"`{_short(text)}` has {counted(len(digits), 'digit')}: numbers have {RANGE_TEXT}"
        )
    if not digits:
        return Fraction(0)
    if exponent_text is not None and len(exponent_text.lstrip("+-").lstrip("0")) > 6:
        raise NumberError(f"`{_short(text)}` is out of range: numbers have {RANGE_TEXT}")
    exponent = int(exponent_text or 0) - len(fraction)
    # The value is digits x 10^exponent, so its magnitude is 10^(len(digits) - 1 + exponent).
    magnitude = len(digits) - 1 + exponent
    if not -MAX_MAGNITUDE <= magnitude < MAX_MAGNITUDE:
        raise NumberError(f"`{_short(text)}` is out of range: numbers have {RANGE_TEXT}")
    # One Fraction, normalised once (arithmetic on Fractions normalises at each
    # step: 2% of a large spec's parse went to reading its numbers so)
    if exponent >= 0:
        value = Fraction(int(digits) * 10**exponent)
    else:
        value = Fraction(int(digits), 10**-exponent)
    return -value if sign == "-" else value


def _short(text: str) -> str:
    text = text.strip()
    return text if len(text) <= 24 else f"{text[:10]}…{text[-10:]}"


def decimal(value: Fraction) -> str:
    """A decimal text: exact for a fraction with a finite expansion, else rounded to
    17 significant digits (never through a float, which overflows)."""
    text = exact_decimal(value)
    if text is not None:
        return text
    with localcontext() as context:
        context.prec = 17
        return str(Decimal(value.numerator) / Decimal(value.denominator))


def exact_or_quotient(text: str) -> Fraction:
    """`exact`, or an exact quotient `p/q` as `rmv sat` writes a witness time."""
    if "/" in text:
        numerator, _, denominator = text.partition("/")
        divisor = exact(denominator)
        if divisor == 0:
            raise NumberError(f"`{_short(text)}` divides by zero")
        return exact(numerator) / divisor
    return exact(text)


def to_json(payload: object, indent: int | None = 2) -> str:
    """JSON text in which every Fraction is written exactly by the runtime's one
    rule (rmvdsl.runtime.engine.to_json): a decimal where one is exact, else the
    quotient as a string (`"1/3"`, which `rmv eval` reads back). No float rounds it."""
    import json

    numbers: list[str] = []

    def mark(value: object) -> object:
        if isinstance(value, Fraction):
            exact_text = exact_decimal(value)
            numbers.append(exact_text if exact_text is not None else json.dumps(str(value)))
            return f"\x00{len(numbers) - 1}\x00"
        if isinstance(value, dict):
            return {key: mark(item) for key, item in value.items()}
        if isinstance(value, list | tuple):
            return [mark(item) for item in value]
        return value

    text = json.dumps(mark(payload), indent=indent)
    return re.sub(r'"\\u0000(\d+)\\u0000"', lambda m: numbers[int(m.group(1))], text)
