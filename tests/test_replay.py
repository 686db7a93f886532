"""The runtime and `rmv replay` on the CARLA braking recordings, written by
examples/carla/make_recordings.py into a temporary folder; expectations derived by
hand from the scenario in that script's docstring."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from fractions import Fraction

import pytest
from conftest import EXAMPLES, ROOT

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime import influx
from rmvdsl.runtime import spec as ir

START = Fraction(1_700_000_000)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    out = tmp_path_factory.mktemp("recordings")
    subprocess.run(
        [sys.executable, str(EXAMPLES / "carla" / "make_recordings.py"), str(out)],
        check=True, capture_output=True,
    )  # fmt: skip
    return out


def _replay(rmv, recording, *extra):
    result = rmv("replay", str(EXAMPLES / "carla" / "abs.rmv"), str(recording), *extra)
    return result


def _records(text):
    return [json.loads(line, parse_float=Fraction) for line in text.splitlines()]


def test_the_known_violation_of_abscheck(rmv, recordings):
    result = _replay(rmv, recordings / "braking.bag", "--format", "jsonl")
    assert result.code == 1, result.out
    records = _records(result.out)
    states = [(r["time"] - START, r["state"]) for r in records if r["kind"] == "state"]
    assert states == [
        (0, "Cruising"), (Fraction("10.1"), "HardBraking"), (Fraction("12.5"), "Stopped"),
        (13, "Cruising"), (Fraction("18.1"), "HardBraking"), (23, "Stopped"),
    ]  # fmt: skip
    verdicts = [
        (r["verdict"], r["from"] - START, r["to"] - START, r["bounds"])
        for r in records
        if r["kind"] == "verdict" and r["property"] == "ABSCheck"
    ]
    # duration[10s](HardBraking) < 4s: [t, t+10] holds 2.4 s of the first brake and
    # 4.9 s of the second; it reaches 4 s from 9.7 (2.4 + 1.6) until 19 (4 of 18.1-23).
    assert verdicts[:3] == [
        ("true", 0, Fraction("9.7"), "[)"),
        ("false", Fraction("9.7"), 19, "[]"),
        ("true", 19, Fraction("23.95"), "()"),
    ]
    assert verdicts[3][0] == "unknown"


def test_the_same_output_from_bag_mcap_and_db3(rmv, recordings):
    outputs = [
        _replay(rmv, recordings / name, "--format", "jsonl").out
        for name in ("braking.bag", "braking_mcap", "braking_db3")
    ]
    assert outputs[0] == outputs[1] == outputs[2]


def test_text_output_and_a_report(rmv, recordings, tmp_path):
    png = tmp_path / "timeline.png"
    result = _replay(rmv, recordings / "braking.bag", "--report", str(png))
    assert result.code == 1
    assert "verdict   ABSCheck: false on [1700000009.7, 1700000019]" in result.out
    assert result.out.rstrip().endswith("FAILED: 1 violations, 0 intrusions")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = tmp_path / "timeline.html"
    assert _replay(rmv, recordings / "braking.bag", "--report", str(page)).code == 1
    text = page.read_text(encoding="utf-8")
    assert "data:image/png;base64," in text
    assert not re.search(r"(src|href)=.https?:", text)  # nothing fetched from a network


def test_damaged_and_missing_input(rmv, recordings, tmp_path):
    broken = tmp_path / "broken.bag"
    broken.write_bytes((recordings / "braking.bag").read_bytes()[:5000])
    result = _replay(rmv, broken)
    assert result.code == 2 and "cannot read the recording" in result.err
    result = _replay(rmv, tmp_path / "absent.bag")
    assert result.code == 2 and "no such file" in result.err


def _event(expr, window=None, fill="null", every=None, span=None):
    number = ir.ValueType("float", "float64", 0)
    return ir.Event(
        "E", "value", expr, number, ("x",), None,
        None if window is None else ir.Window(Fraction(window), Fraction(0)), (),
        ir.Fill(fill), "asc", None, None,
        None if every is None else Fraction(every), None if span is None else Fraction(span),
        "", "",
    )  # fmt: skip


def _ref():
    return ir.Ref("x", "variable", ir.ValueType("float", "float64", 0))


def _call(name, *args):
    return ir.Call(name, (*args,), ir.ValueType("float", "float64", 0))


def _run(event, points, until):
    state = influx.EventState(influx.WindowedQuery(event))
    for t, v in points:
        state.add(influx.Row(t, {"x": v}))
    return influx.drain(state, until)


S = 10**9


def test_mean_per_window_at_its_start():
    points = [(0, 1.0), (S // 2, 3.0), (S, 10.0), (3 * S, 4.0)]
    out = _run(_event(_call("mean", _ref()), window=1), points, 10 * S)
    assert out == [(0, 2.0), (S, 10.0), (3 * S, 4.0)]  # fill null: nothing at 2 s


def test_fills():
    points = [(0, 1.0), (3 * S, 4.0)]
    mean = _call("mean", _ref())
    # One run over the whole minute, so fill sees both points.
    run = {"every": 60, "span": 60}
    assert _run(_event(mean, 1, "previous", **run), points, 4 * S)[:4] == [
        (0, 1.0), (S, 1.0), (2 * S, 1.0), (3 * S, 4.0)
    ]  # fmt: skip
    assert _run(_event(mean, 1, "linear", **run), points, 4 * S) == [
        (0, 1.0), (S, 2.0), (2 * S, 3.0), (3 * S, 4.0)
    ]  # fmt: skip
    count = _call("count", _ref())
    assert _run(_event(count, 1, "null", **run), points, 4 * S)[:4] == [
        (0, 1), (S, 0), (2 * S, 0), (3 * S, 1)
    ]  # fmt: skip


def test_derivative_of_means_within_each_run():
    """Each run is its own query: with every = the window (InfluxDB's default), a
    run holds one window and the derivative has no previous point in it."""
    inner = _call("mean", _ref())
    second = ir.Time("1s", Fraction(1), ir.ValueType("duration", None, 1))
    derivative = ir.Call("derivative", (inner, second), ir.ValueType("float", None, -1))
    points = [(k * S // 10, float(k)) for k in range(30)]  # x = 10 t
    assert _run(_event(derivative, window=1), points, 3 * S) == []
    wide = _run(_event(derivative, window=1, every=60, span=60), points, 3 * S)
    assert wide == [(S, pytest.approx(10.0)), (2 * S, pytest.approx(10.0))]


def test_influxdb_reducers():
    pts = [(i, v) for i, v in enumerate([3, 1, 2, 2, 5])]
    assert influx.reduce("median", pts, None) == 2.0
    assert influx.reduce("mode", pts, None) == 2
    assert influx.reduce("percentile", pts, 50) == 2  # floor(5 * 0.5 + 0.5) - 1 = 2
    assert influx.reduce("stddev", [(0, 1.0)], None) is None
    assert influx.reduce("spread", pts, None) == 4
    assert influx.reduce("count", [], None) == 0


def test_the_resolved_spec_runs_in_the_runtime():
    spec = lower(check(str(ROOT / "examples" / "carla" / "abs.rmv")))
    from rmvdsl.runtime.engine import Runtime

    runtime = Runtime(spec)
    runtime.end(0)
    assert runtime.records() == []
