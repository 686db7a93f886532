"""Value events as InfluxDB 1.x computes them (docs/runtime.md, "Events").

Standard library only. A windowed event is a continuous query: it runs every
`resample_every` over `[start, end)` computed exactly as InfluxDB's continuous
querier computes it, groups rows into epoch-aligned windows `time(interval,
offset)` stamped at their start, applies the functions and `fill` as InfluxQL's
iterators do, and a later run overwrites the points an earlier one wrote. A point is
emitted once no later run can cover its window. An event with no window is a raw
query: one point per row, at the row's time.

Times are integer nanoseconds, as InfluxDB stores them.
"""

from __future__ import annotations

import bisect
import math
import operator
import random
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from rmvdsl.builtins import function as builtin
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime import values

NS = 1_000_000_000
MISSING = None  # a null: no value


def nanoseconds(seconds: Fraction) -> int:
    """A duration in whole nanoseconds, as InfluxDB holds every duration."""
    return math.floor(seconds * NS)


@dataclass
class Row:
    """Values of one source (a topic's message, or one event's point) at one time:
    InfluxDB's point, whose fields are the variables read from it."""

    time: int
    fields: dict[str, Any]


def _window_start(t: int, interval: int, offset: int) -> int:
    return t - (t - offset) % interval


# ---- evaluation of expressions ----


def evaluate(expr: ir.Expr, lookup: Callable[[str], Any]) -> Any:
    """The value of an expression with no function calls, or MISSING when a name it
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
            return _constant(_number(expr))
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
        case ir.Binary():
            return _compile_binary(expr, _compile(expr.left), _compile(expr.right))
    raise ValueError(f"cannot evaluate {type(expr).__name__} here")


def _constant(value: Any) -> Evaluator:
    return lambda lookup: value


def _compile_binary(expr: ir.Binary, left: Evaluator, right: Evaluator) -> Evaluator:
    op = expr.op
    if op in ("and", "or"):
        return _connective(op == "or", left, right)
    if op in _ORDERING:
        compare = _ORDERING[op]

        def ordering(lookup: Callable[[str], Any]) -> Any:
            a, b = left(lookup), right(lookup)
            kinds = type(a), type(b)
            if kinds == (float, float) or kinds == (int, int):
                return compare(a, b)  # the common case: no conversion to decide
            if a is MISSING or b is MISSING:
                return MISSING
            return values.compare(op, a, b)

        return ordering
    return lambda lookup: _binary(expr, left(lookup), lambda: right(lookup))


_ORDERING: dict[str, Callable[[Any, Any], bool]] = {
    "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge,
}  # fmt: skip


def unary(op: str, operand: Any) -> Any:
    if operand is MISSING:
        return MISSING
    if op == "not":
        return operand is False
    return values.negate(operand)


def _connective(deciding: bool, left: Evaluator, right: Evaluator) -> Evaluator:
    """`_kleene` compiled for the runtime's hot path (a condition at every message):
    no closure made per evaluation."""

    def connective(lookup: Callable[[str], Any]) -> Any:
        a = left(lookup)
        return deciding if a is deciding else _settled(deciding, a, right(lookup))

    return connective


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


def _number(node: ir.Number) -> int | float:
    return values.literal(node.text)


def _binary(expr: ir.Binary, left: Any, right_of: Callable[[], Any]) -> Any:
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


# ---- functions over a window's values ----


def _sorted(points: list[tuple[int, Any]]) -> list[tuple[int, Any]]:
    return sorted(points, key=lambda p: (p[1], p[0]))


def _mean(vals: list[Any]) -> float:
    # InfluxDB's mean: a running mean in doubles, the order of the points.
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
    mean = _mean(numbers)
    variance = sum((v - mean) ** 2 for v in numbers)
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
            result = abs(value)
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
    if values.is_int(value):
        return value
    if math.isnan(value) or math.isinf(value):
        return value
    if name == "ceil":
        return float(math.ceil(value))
    if name == "floor":
        return float(math.floor(value))
    return float(math.floor(abs(value) + 0.5)) * (1.0 if value >= 0 else -1.0)  # Go's Round


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


# ---- one event's query ----


def _second(call: ir.Call) -> Any:
    """The constant second argument: a time in nanoseconds, or a number."""
    fn = builtin(call.function)
    if len(call.args) < 2:
        if fn.second == "time":
            return 1 if call.function == "elapsed" else NS
        return None
    arg = call.args[1]
    if isinstance(arg, ir.Time):
        return nanoseconds(arg.seconds)
    if isinstance(arg, ir.Number):
        return _number(arg)
    raise ValueError(f"the second argument of {call.function} is not a constant")


# Transformations for which InfluxDB reads one window more, before a query's time
# range, so that a run's first window has a predecessor (query/select.go moves the
# input's StartTime back one interval for them; cumulative_sum is not among them).
LOOKBACK = frozenset(
    {"derivative", "non_negative_derivative", "difference", "non_negative_difference",
     "elapsed", "moving_average"}
)  # fmt: skip


def _aggregating(call: ir.Call) -> bool:
    return builtin(call.function).group in ("aggregation", "selector")


def _calls(expr: ir.Expr) -> list[ir.Call]:
    out: list[ir.Call] = []
    stack: list[Any] = [expr]
    while stack:
        node = stack.pop()
        if isinstance(node, ir.Call):
            out.append(node)
            stack.extend(node.args)
        elif isinstance(node, ir.Unary):
            stack.append(node.operand)
        elif isinstance(node, ir.Binary):
            stack.extend((node.left, node.right))
    return out


class RawQuery:
    """An event with no window: one point per row that has every value the
    expression reads (and passes `where`), with the transformations streaming over
    the rows."""

    def __init__(self, event: ir.Event) -> None:
        self.event = event
        calls = [c for c in _calls(event.expr) if c.function != "atan2"]  # its y: a series
        self.seconds = {id(c): _second(c) for c in calls}
        self.streams: dict[int, Stream] = {
            id(c): Stream(c.function, self.seconds[id(c)]) for c in calls if c.function in STREAMS
        }

    def row(self, row: Row) -> Any:
        if self.event.where is not None and evaluate(self.event.where, row.fields.get) is not True:
            return MISSING
        return self._value(self.event.expr, row)

    def _value(self, expr: ir.Expr, row: Row) -> Any:
        if isinstance(expr, ir.Call):
            inner = self._value(expr.args[0], row)
            if inner is MISSING:
                return MISSING
            stream = self.streams.get(id(expr))
            if stream is not None:
                return stream.push(row.time, inner)
            if expr.function == "atan2":
                return _atan2(inner, self._value(expr.args[1], row))
            return elementwise(expr.function, inner, self.seconds[id(expr)])
        if isinstance(expr, ir.Binary):
            return _binary(expr, self._value(expr.left, row), lambda: self._value(expr.right, row))
        if isinstance(expr, ir.Unary):
            return unary(expr.op, self._value(expr.operand, row))
        return evaluate(expr, row.fields.get)


Series = dict[int, Any]  # window start (or a point's own time) -> value


@dataclass
class Run:
    """One execution of a continuous query over [start, end)."""

    start: int
    end: int


class WindowedQuery:
    """A continuous query: runs, windows, fill, and the points written."""

    def __init__(self, event: ir.Event) -> None:
        assert event.window is not None
        self.event = event
        self.interval = nanoseconds(event.window.interval)
        self.offset = nanoseconds(event.window.offset) % self.interval
        # The resolved spec fills InfluxDB's defaults: every = the interval, and
        # for = the longer of the interval and every.
        every, span = ir.resampling(event.window.interval, event.resample_every, event.resample_for)
        self.every, self.span = nanoseconds(every), nanoseconds(span)
        # How far before a run's range its rows reach (one window for LOOKBACK).
        looks_back = any(c.function in LOOKBACK for c in _calls(event.expr))
        self.lookback = self.interval if looks_back else 0

    def run_at(self, now: int) -> Run:
        """InfluxDB's continuous querier, services/continuous_querier/service.go:
        the range of the run scheduled at `now`."""
        interval, offset = self.interval, self.offset
        every = min(self.every, interval)
        start = _truncate(now + interval - self.span - offset - 1, interval) + offset
        end = _truncate(now + interval - every - offset, interval) + offset
        return Run(start, end)

    def first_run(self, t: int) -> int:
        """The first scheduled run whose range can hold time t."""
        now = _truncate(t - self.offset, self.every) + self.offset
        while self.run_at(now).end > t:
            now -= self.every
        return now + self.every

    def execute(self, run: Run, rows: Sequence[Row]) -> list[tuple[int, Any]]:
        """The points the run writes from `rows` (those of its range and `lookback`
        before it, oldest first),
        in time order (several at one time: the last written wins, as InfluxDB
        overwrites a point of the same series and time)."""
        event = self.event
        selected = list(rows)
        if event.where is not None:
            selected = [r for r in selected if evaluate(event.where, r.fields.get) is True]
        windows = range(run.start, run.end, self.interval)
        expr = event.expr
        if isinstance(expr, ir.Call) and expr.function in MULTI:
            points = self._multi_points(expr, selected, windows)
        else:
            series = self._series(expr, selected, windows)
            found = series.items() if isinstance(series, dict) else ()
            points = sorted((t, v) for t, v in found if v is not MISSING and not _nan(v))
        if event.limit is not None:
            points = points[-event.limit :] if event.order == "desc" else points[: event.limit]
        return points

    def _series(self, expr: ir.Expr, rows: list[Row], windows: range) -> Any:
        """A dict of window -> value for anything that depends on the rows, or a
        constant."""
        if isinstance(expr, ir.Call):
            if _aggregating(expr):
                return self._aggregate(expr, rows, windows)
            if expr.function in LOOKBACK:
                before = range(windows.start - self.interval, windows.stop, windows.step)
                inner = self._series(expr.args[0], rows, before)
            else:
                inner = self._series(expr.args[0], rows, windows)
            if expr.function == "atan2":  # atan2(y, x): two series, joined on time
                return _join(_atan2, inner, self._series(expr.args[1], rows, windows))
            if expr.function in STREAMS:
                stream = Stream(expr.function, _second(expr))
                out: Series = {}
                for t in sorted(inner):
                    if inner[t] is not MISSING:
                        result = stream.push(t, inner[t])
                        if result is not MISSING and t >= windows.start:
                            out[t] = result
                return out
            second = _second(expr)
            return {t: elementwise(expr.function, v, second) for t, v in inner.items()}
        if isinstance(expr, ir.Binary):
            left = self._series(expr.left, rows, windows)
            right = self._series(expr.right, rows, windows)
            return _join(_operator(expr), left, right)
        if isinstance(expr, ir.Unary):
            operand = self._series(expr.operand, rows, windows)
            if not isinstance(operand, dict):
                return unary(expr.op, operand)
            return {t: unary(expr.op, v) for t, v in operand.items()}
        return evaluate(expr, lambda name: MISSING)

    def _points(self, arg: ir.Expr, rows: list[Row]) -> list[tuple[int, Any]]:
        """The values a function reads: a NaN is no point (InfluxDB refuses to store
        one), so `min`, `max` and the rest skip it, as numpy's `nanmin` does."""
        out = []
        for row in rows:
            value = evaluate(arg, row.fields.get)
            if value is not MISSING and not _nan(value):
                out.append((row.time, value))
        return out

    def _aggregate(self, call: ir.Call, rows: list[Row], windows: range) -> Series:
        points = self._points(call.args[0], rows)
        if not points:
            return {}  # InfluxDB fills nothing where the range holds no point
        second = _second(call)
        if call.function == "integral":
            found = integral(points, self.interval, self.offset, second)
        else:
            grouped: dict[int, list[tuple[int, Any]]] = {}
            for point in points:
                key = _window_start(point[0], self.interval, self.offset)
                grouped.setdefault(key, []).append(point)
            found = {w: reduce(call.function, ps, second) for w, ps in grouped.items()}
        # rows reach `lookback` before the range: only a LOOKBACK caller asks for it
        found = {w: v for w, v in found.items() if v is not MISSING and w in windows}
        return _fill(self.event.fill, call, found, windows)

    def _multi_points(self, call: ir.Call, rows: list[Row], windows: range) -> list:
        points = self._points(call.args[0], rows)
        second = _second(call)
        n = int(second) if second is not None else 0
        times = [t for t, _ in points]
        # InfluxDB stamps distinct's points at the window's start (an interval
        # iterator); top, bottom and sample keep their points' own times.
        keep_time = call.function != "distinct"
        out: list[tuple[int, Any]] = []
        for window in windows:
            low = bisect.bisect_left(times, window)
            high = bisect.bisect_left(times, window + self.interval)
            chosen = multi(call.function, points[low:high], n, window)
            out.extend((t if keep_time else window, v) for t, v in chosen)
        return out


def _nan(value: Any) -> bool:
    return isinstance(value, float) and math.isnan(value)


def _join(combine: Callable[[Any, Any], Any], left: Any, right: Any) -> Any:
    """Two series joined on time (InfluxQL's binary iterator: a time missing on
    one side is null), or a series with a constant."""
    if not isinstance(left, dict) and not isinstance(right, dict):
        return combine(left, right)
    if not isinstance(left, dict):
        return {t: combine(left, v) for t, v in right.items()}
    if not isinstance(right, dict):
        return {t: combine(v, right) for t, v in left.items()}
    times = sorted(set(left) | set(right))
    return {t: combine(left.get(t, MISSING), right.get(t, MISSING)) for t in times}


def _operator(expr: ir.Binary) -> Callable[[Any, Any], Any]:
    return lambda left, right: _binary(expr, left, _const(right))


def _atan2(y: Any, x: Any) -> Any:
    return MISSING if x is MISSING else elementwise("atan2", y, x)


def _const(value: Any) -> Callable[[], Any]:
    return lambda: value


def _fill(fill: ir.Fill, call: ir.Call, found: Series, windows: range) -> Series:
    """InfluxQL's fill iterator over the run's windows (query/iterator.gen.go). A
    continuous query writes INTO a measurement, and InfluxDB then turns `fill(null)`
    into `fill(none)` (query/iterator.go): no point for an empty window, even for
    `count`. `previous` carries the last real value (none before the first);
    `linear` interpolates between real neighbours only."""
    mode = fill.mode
    if mode in ("null", "none"):
        return found
    if mode == "number":
        assert fill.value is not None
        number = _fill_number(_number(fill.value), call.type.kind)
        if number is MISSING:
            return found
        return {w: found.get(w, number) for w in windows}
    out: Series = {}
    real = sorted(found)
    previous: tuple[int, Any] | None = None
    for w in windows:
        if w in found:
            out[w] = found[w]
            previous = (w, found[w])
        elif previous is not None and mode == "previous":
            out[w] = previous[1]
        elif previous is not None and mode == "linear":
            index = bisect.bisect_right(real, w)
            if index < len(real):
                following = real[index]
                out[w] = _linear(w, previous, (following, found[following]), windows.step)
    return out


def _fill_number(number: int | float, kind: str) -> Any:
    """The fill value cast to the series' type, as the fill iterator casts it
    (an integer series truncates 2.7 to 2); no fill for bools and strings."""
    if kind == "int":
        return int(number)
    if kind in ("float", "time", "duration"):
        return float(number)
    return MISSING


def _linear(w: int, previous: tuple[int, Any], following: tuple[int, Any], step: int) -> Any:
    x0, x1, x = previous[0] // step, following[0] // step, w // step
    slope = (float(following[1]) - float(previous[1])) / float(x1 - x0)
    value = slope * float(x - x0) + float(previous[1])
    if values.is_int(previous[1]) and values.is_int(following[1]):
        return int(value)
    return value


def integral(points: list[tuple[int, Any]], interval: int, offset: int, unit: int) -> Series:
    """InfluxDB's integral reducer (query/functions.go): trapezoids between
    consecutive points, the area up to a window's end interpolated onto the next
    point; the window's sum written at its start."""
    out: Series = {}
    prev: tuple[int, float] | None = None
    start = end = 0
    total = 0.0
    for time, raw in points:
        value = float(raw)
        if prev is None:
            prev = (time, value)
            start = _window_start(time, interval, offset)
            end = start + interval
            continue
        if time == prev[0]:
            prev = (time, value)
            continue
        if time >= end:
            if prev[0] != end:
                at_end = prev[1] + (value - prev[1]) / (time - prev[0]) * (end - prev[0])
                total += 0.5 * (at_end + prev[1]) * ((end - prev[0]) / unit)
                prev = (end, at_end)
            out[start] = total
            start = _window_start(time, interval, offset)
            end = start + interval
            total = 0.0
        total += 0.5 * (value + prev[1]) * ((time - prev[0]) / unit)
        prev = (time, value)
    if prev is not None and prev[0] != start:
        out[start] = total
    return out


def _truncate(t: int, d: int) -> int:
    return t - t % d


@dataclass
class EventState:
    """What a windowed query holds between runs: the rows its next runs can read,
    the points written but not yet final, and the next run's time."""

    query: WindowedQuery
    rows: list[Row] = field(default_factory=list)
    times: list[int] = field(default_factory=list)
    written: dict[int, Any] = field(default_factory=dict)
    next_run: int | None = None
    final: int | None = None  # points before this time are final

    def add(self, row: Row) -> None:
        index = bisect.bisect_right(self.times, row.time)
        self.times.insert(index, row.time)
        self.rows.insert(index, row)
        if self.next_run is None:
            self.next_run = self.query.first_run(row.time)

    def advance(self, now: int) -> list[tuple[int, Any]]:
        """Execute every run scheduled at or before `now`; return the points that
        became final, oldest first."""
        out: list[tuple[int, Any]] = []
        query = self.query
        while self.next_run is not None and self.next_run <= now:
            run = query.run_at(self.next_run)
            if run.end > run.start:
                low = bisect.bisect_left(self.times, run.start - query.lookback)
                high = bisect.bisect_left(self.times, run.end)
                if high > low:
                    for time, value in query.execute(run, self.rows[low:high]):
                        self.written[time] = value
            self.next_run += query.every
            boundary = query.run_at(self.next_run).start
            out.extend(self._settle(boundary))
            if not self.rows and not self.written:
                self.next_run = None  # idle until the next row
                break
        return out

    def _settle(self, boundary: int) -> list[tuple[int, Any]]:
        """Points before `boundary` are final: no later run reads their window."""
        self.final = boundary
        # the next run reads from `lookback` before its range
        cut = bisect.bisect_left(self.times, boundary - self.query.lookback)
        if cut:
            del self.times[:cut]
            del self.rows[:cut]
        done = sorted(t for t in self.written if t < boundary)
        return [(t, self.written.pop(t)) for t in done]

    def final_before(self, bound: int) -> int:
        """Up to where the points are final, when every row before `bound` is in:
        a point is stamped at its window's start, so a later run (or a row still
        to come) can write no earlier than the start of the next run's range."""
        next_run = self.next_run if self.next_run is not None else self.query.first_run(bound)
        return min(bound, self.query.run_at(next_run).start)


def drain(state: EventState, limit: int) -> list[tuple[int, Any]]:
    """At the end of the input: run until every window holding data is final, and
    keep the points before `limit` (the end of the input)."""
    out: list[tuple[int, Any]] = []
    while state.next_run is not None and (state.rows or state.written):
        out.extend(state.advance(state.next_run))
    return [p for p in out if p[0] < limit]
