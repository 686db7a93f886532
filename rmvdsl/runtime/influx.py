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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from rmvdsl.lang.builtins import function as builtin
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.expressions import (
    Evaluator,
    binary,
    compiled,
    evaluate,
    kleene_and,
    kleene_or,
    number_value,
    unary,
)
from rmvdsl.runtime.fill import _fill, integral
from rmvdsl.runtime.functions import MULTI, STREAMS, Stream, elementwise, multi, reduce
from rmvdsl.runtime.series import MISSING, NS, Row, Series, nanoseconds, truncate, window_start

__all__ = [
    "MISSING",
    "MULTI",
    "NS",
    "STREAMS",
    "Evaluator",
    "EventState",
    "RawQuery",
    "Row",
    "Run",
    "Series",
    "Stream",
    "WindowedQuery",
    "compiled",
    "drain",
    "elementwise",
    "evaluate",
    "integral",
    "kleene_and",
    "kleene_or",
    "multi",
    "nanoseconds",
    "reduce",
    "unary",
]  # fmt: skip

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
        return number_value(arg)
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
            return binary(expr, self._value(expr.left, row), lambda: self._value(expr.right, row))
        if isinstance(expr, ir.Unary):
            return unary(expr.op, self._value(expr.operand, row))
        return evaluate(expr, row.fields.get)


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
        start = truncate(now + interval - self.span - offset - 1, interval) + offset
        end = truncate(now + interval - every - offset, interval) + offset
        return Run(start, end)

    def first_run(self, t: int) -> int:
        """The first scheduled run whose range can hold time t."""
        now = truncate(t - self.offset, self.every) + self.offset
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
            where = compiled(event.where)
            selected = [r for r in selected if where(r.fields.get) is True]
        windows = range(run.start, run.end, self.interval)
        expr = event.expr
        if isinstance(expr, ir.Call) and expr.function in MULTI:
            points = self._multi_points(expr, selected, windows)
        else:
            series = self._series(expr, selected, windows)
            found = series.items() if isinstance(series, dict) else ()
            points = sorted((t, v) for t, v in found if v is not MISSING and not _unstorable(v))
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
        """The values a function reads: a NaN or an infinity is no point (InfluxDB
        refuses to store one, and the collector leaves it out: lineproto), so `min`,
        `max` and the rest skip it, as numpy's `nanmin` does."""
        value_of, isfinite = compiled(arg), math.isfinite
        out = []
        for row in rows:
            value = value_of(row.fields.get)
            if value is not MISSING and not (isinstance(value, float) and not isfinite(value)):
                out.append((row.time, value))  # _unstorable inlined: a point per row
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
                key = window_start(point[0], self.interval, self.offset)
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


def _unstorable(value: Any) -> bool:
    """A NaN or an infinity: InfluxDB writes no such point (a run's other points
    are written: checked against influxd)."""
    return isinstance(value, float) and not math.isfinite(value)


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
    return lambda left, right: binary(expr, left, _const(right))


def _atan2(y: Any, x: Any) -> Any:
    return MISSING if x is MISSING else elementwise("atan2", y, x)


def _const(value: Any) -> Callable[[], Any]:
    return lambda: value


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
        times = self.times
        if not times or times[-1] <= row.time:  # rows come mostly in time order
            times.append(row.time)
            self.rows.append(row)
        else:
            index = bisect.bisect_right(times, row.time)
            times.insert(index, row.time)
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
