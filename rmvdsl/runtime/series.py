"""Times and values as InfluxDB holds them: integer nanoseconds, a null, a row
of one source's fields at one time, and a series of points by time."""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

NS = 1_000_000_000
MISSING = None  # a null: no value


def nanoseconds(seconds: Fraction) -> int:
    """A duration in whole nanoseconds, as InfluxDB holds every duration."""
    return math.floor(seconds * NS)


@dataclass(slots=True)
class Row:
    """Values of one source (a topic's message, or one event's point) at one time:
    InfluxDB's point, whose fields are the variables read from it."""

    time: int
    fields: dict[str, Any]


def window_start(t: int, interval: int, offset: int) -> int:
    return t - (t - offset) % interval


Series = dict[int, Any]  # window start (or a point's own time) -> value


def truncate(t: int, d: int) -> int:
    return t - t % d
