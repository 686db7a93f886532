"""InfluxQL's functions over a window's values: aggregates and selectors
(`reduce`), those that give several points (`multi`), element-wise
transformations, and the streaming ones that read the previous windows."""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from typing import Any

from rmvdsl.runtime import values
from rmvdsl.runtime.series import MISSING


def _sorted(points: list[tuple[int, Any]]) -> list[tuple[int, Any]]:
    return sorted(points, key=lambda p: (p[1], p[0]))


def _mean(vals: list[Any]) -> float:
    """InfluxDB's mean (FloatMeanReducer): the sum in doubles, in the points'
    order, over the count (checked against influxd: a running mean differs in
    the last bit in about half of the windows)."""
    total = 0.0
    for value in vals:
        total += float(value)
    return total / len(vals)


def _running_mean(vals: list[Any]) -> float:
    """The mean `stddev` subtracts (FloatStddevReducer): a running mean."""
    mean = 0.0
    for count, value in enumerate(vals, 1):
        mean += (float(value) - mean) / count
    return mean


def _median(points: list[tuple[int, Any]]) -> Any:
    ordered = [v for _, v in _sorted(points)]
    n = len(ordered)
    if n == 1:
        return float(ordered[0])
    if n % 2 == 0:
        low, high = ordered[n // 2 - 1], ordered[n // 2]
        return float(low) + float(high - low) / 2
    return float(ordered[n // 2])


def _mode(points: list[tuple[int, Any]]) -> Any:
    """InfluxDB's loop, exactly: over the values sorted, a value takes the lead only
    when its count exceeds the leader's, or equals it while its first point is not
    newer; a value seen once never displaces the first."""
    if len(points) == 1:
        return points[0][1]
    ordered = _sorted(points)
    most_freq, current_freq = 0, 0
    current, most = ordered[0][1], ordered[0][1]
    current_time = most_time = ordered[0][0]
    for time, value in ordered:
        if value != current:
            current_freq, current, current_time = 1, value, time
            continue
        current_freq += 1
        if most_freq > current_freq or (most_freq == current_freq and current_time > most_time):
            continue
        most_freq, most, most_time = current_freq, value, current_time
    return most


def _stddev(vals: list[Any]) -> Any:
    if len(vals) < 2:
        return MISSING  # InfluxDB gives NaN, which it cannot write: no point
    numbers = [float(v) for v in vals if not (isinstance(v, float) and math.isnan(v))]
    mean = _running_mean(numbers)
    variance = 0.0
    for value in numbers:  # a square too great for a double is infinite, as in Go
        variance += (value - mean) * (value - mean)
    return math.sqrt(variance / (len(numbers) - 1))


def _percentile(points: list[tuple[int, Any]], percent: float) -> Any:
    index = math.floor(len(points) * percent / 100.0 + 0.5) - 1
    if index < 0 or index >= len(points):
        return MISSING
    return _sorted(points)[index][1]


def _sum(vals: list[Any]) -> Any:
    total: Any = 0 if all(values.is_int(v) for v in vals) else 0.0
    for value in vals:
        total = values.arithmetic("+", total, value)
    return total


def _spread(vals: list[Any]) -> Any:
    return values.arithmetic("-", max(vals), min(vals))


def _extreme(points: list[tuple[int, Any]], greatest: bool) -> Any:
    # The first point (oldest) wins among equal values, as InfluxDB's selectors do.
    best = points[0]
    for point in points[1:]:
        if (point[1] > best[1]) if greatest else (point[1] < best[1]):
            best = point
    return best[1]


def reduce(name: str, points: list[tuple[int, Any]], second: Any) -> Any:
    """One aggregation or selector over a window's (time, value) points, oldest first,
    or MISSING. `count` of nothing is 0; the rest give no value for no points."""
    if name == "count":
        return len(points)
    if not points:
        return MISSING
    vals = [v for _, v in points]
    match name:
        case "mean":
            return _mean(vals)
        case "median":
            return _median(points)
        case "mode":
            return _mode(points)
        case "spread":
            return _spread(vals)
        case "stddev":
            return _stddev(vals)
        case "sum":
            return _sum(vals)
        case "first":
            return points[0][1]
        case "last":
            return points[-1][1]
        case "max":
            return _extreme(points, True)
        case "min":
            return _extreme(points, False)
        case "percentile":
            return _percentile(points, float(second))
    raise ValueError(f"{name} is not a reduction of one value")


def multi(name: str, points: list[tuple[int, Any]], n: int, seed: int) -> list[tuple[int, Any]]:
    """The functions that select several points: `top`/`bottom` (the N greatest or
    smallest, at their own times, ties to the oldest), `distinct` (each value once,
    in the order of its first time, ties by value: query/functions.gen.go sorts the
    points so) and `sample` (N at random, by a generator seeded with the window)."""
    if name == "distinct":
        seen: dict[Any, int] = {}
        for time, value in points:
            seen.setdefault(value, time)
        return [(-1, v) for v, _ in sorted(seen.items(), key=lambda item: (item[1], item[0]))]
    if name in ("top", "bottom"):
        ranked = sorted(points, key=lambda p: ((-p[1] if name == "top" else p[1]), p[0]))
        return sorted(ranked[:n])
    if name == "sample":
        if len(points) <= n:
            return list(points)
        return sorted(random.Random(seed).sample(points, n))
    raise ValueError(f"{name} does not select points")


MULTI = frozenset({"top", "bottom", "distinct", "sample"})
# The transformations of one value (`elementwise`): a condition may apply them to
# the newest values it reads; the others (STREAMS) need a series of points.
ELEMENTWISE = frozenset(
    {"abs", "ceil", "floor", "round", "pow", "log", "atan2", "sqrt", "exp", "ln", "log2",
     "log10", "sin", "cos", "tan", "asin", "acos", "atan"}
)  # fmt: skip
_MATH: dict[str, Callable[..., float]] = {
    "sqrt": math.sqrt, "exp": math.exp, "ln": math.log, "log2": math.log2,
    "log10": math.log10, "sin": math.sin, "cos": math.cos, "tan": math.tan,
    "asin": math.asin, "acos": math.acos, "atan": math.atan,
}  # fmt: skip


def elementwise(name: str, value: Any, second: Any) -> Any:
    """The transformations of one value; MISSING where the result is not a number
    InfluxDB can store (the logarithm of a negative number is NaN)."""
    if value is MISSING:
        return MISSING
    try:
        result: Any
        if name == "abs":
            result = values.wrap(abs(value)) if values.is_int(value) else abs(value)
        elif name in ("ceil", "floor", "round"):
            result = _rounding(name, value)
        elif name == "pow":
            result = math.pow(float(value), float(second))
        elif name == "log":
            result = math.log(float(value), float(second))
        elif name == "atan2":
            result = math.atan2(float(value), float(second))
        else:
            result = _MATH[name](float(value))
    except (ValueError, ZeroDivisionError, OverflowError):
        return MISSING
    if isinstance(result, float) and math.isnan(result):
        return MISSING
    return result


def _rounding(name: str, value: Any) -> Any:
    """Go's math.Ceil, Floor and Round (halves away from zero) on a double: exact,
    and a zero keeps the operand's sign (`ceil(-0.5)` is -0.0), as IEEE's
    roundToIntegral does; an integer is itself."""
    if values.is_int(value) or math.isnan(value) or math.isinf(value):
        return value
    if name == "ceil":
        result = float(math.ceil(value))
    elif name == "floor":
        result = float(math.floor(value))
    else:
        whole = float(math.trunc(value))  # value - whole is exact: no `value + 0.5`
        result = whole + math.copysign(1.0, value) if abs(value - whole) >= 0.5 else whole
    return math.copysign(result, value) if result == 0 else result


class Stream:
    """A transformation over a series of points (derivative, difference,
    moving_average, cumulative_sum, elapsed), fed in time order: InfluxDB's
    reducers, one point at a time."""

    def __init__(self, name: str, second: Any) -> None:
        self.name = name
        self.second = second
        self.previous: tuple[int, Any] | None = None
        self.buffer: list[Any] = []
        self.total: Any = None

    def push(self, time: int, value: Any) -> Any:
        """The output at `time`, or MISSING."""
        name = self.name
        previous, self.previous = self.previous, (time, value)
        if name == "cumulative_sum":
            self.total = value if self.total is None else values.arithmetic("+", self.total, value)
            return self.total
        if name == "moving_average":
            self.buffer.append(value)
            if len(self.buffer) > self.second:
                del self.buffer[0]
            return _moving_average(self.buffer) if len(self.buffer) == self.second else MISSING
        if previous is None:
            return MISSING
        if time == previous[0]:
            self.previous = previous  # a second point at the same time is skipped
            return MISSING
        if name == "elapsed":
            return (time - previous[0]) // self.second
        diff = values.arithmetic("-", value, previous[1])
        if name.startswith("non_negative") and diff < 0:
            return MISSING
        if name.endswith("difference"):
            return diff
        return float(diff) / ((time - previous[0]) / self.second)


def _moving_average(buffer: list[Any]) -> float:
    if all(values.is_int(v) for v in buffer):
        return float(sum(buffer)) / len(buffer)
    total = 0.0
    for value in buffer:
        total += float(value)
    return total / len(buffer)


STREAMS = frozenset(
    {
        "derivative",
        "non_negative_derivative",
        "difference",
        "non_negative_difference",
        "moving_average",
        "cumulative_sum",
        "elapsed",
    }
)
