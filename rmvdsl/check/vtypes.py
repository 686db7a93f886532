"""The value types of the checker: bool, int, float, string, time, duration.

A numeric value also carries its time exponent (`derivative(x, 1s)` is x per
second: -1), so that a rate of change compared with a value is reported; bare
numbers adapt to any unit.
"""

from __future__ import annotations

from dataclasses import dataclass

from rmvdsl.runtime.spec_terms import value_kind

NUMERIC = frozenset({"int", "float"})


@dataclass(frozen=True)
class VType:
    kind: str  # bool | int | float | string | time | duration | unknown
    ros: str = ""  # the ROS type it comes from, for messages and hover
    rate: int = 0  # time exponent: -1 for a derivative, +1 for an integral
    literal: bool = False  # a constant written in the spec: adapts to units

    @property
    def numeric(self) -> bool:
        return self.kind in NUMERIC

    @property
    def adapts(self) -> bool:
        """A bare number written in the spec: it takes the unit of what it meets."""
        return self.literal and self.kind in NUMERIC and self.rate == 0

    @property
    def exponent(self) -> int:
        """The power of seconds in its unit: 1 for a time, -1 for a rate, 0 for none."""
        return self.rate + (1 if self.kind == "duration" else 0)

    def describe(self) -> str:
        name = self.ros or self.kind
        if self.rate < 0:
            name += " per second" if self.rate == -1 else f" per second^{-self.rate}"
        elif self.rate > 0:
            name += " times seconds" if self.rate == 1 else f" times seconds^{self.rate}"
        return name


UNKNOWN = VType("unknown")
BOOL = VType("bool")
INT = VType("int")
FLOAT = VType("float")
STRING = VType("string")
DURATION = VType("duration")


def from_ros(base: str) -> VType:
    kind = value_kind(base)
    return UNKNOWN if kind is None else VType(kind, base)
