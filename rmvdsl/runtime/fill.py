"""What a window with no value becomes (`fill`), and `integral` over the
windows, as InfluxQL's iterators compute them."""

from __future__ import annotations

import bisect
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime import values
from rmvdsl.runtime.expressions import number_value
from rmvdsl.runtime.series import MISSING, Series, window_start


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
        number = _fill_number(number_value(fill.value), call.type.kind)
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
            start = window_start(time, interval, offset)
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
            start = window_start(time, interval, offset)
            end = start + interval
            total = 0.0
        total += 0.5 * (value + prev[1]) * ((time - prev[0]) / unit)
        prev = (time, value)
    if prev is not None and prev[0] != start:
        out[start] = total
    return out
