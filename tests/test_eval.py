"""`rmv eval`, trace files, lateness, and the monitor's bounded memory."""

from __future__ import annotations

import json
from fractions import Fraction

import pytest
from conftest import rmv_process

from rmvdsl.logic.traces import TraceError, read_trace
from rmvdsl.runtime.rmtld3 import Monitor, merge

BRAKING = (
    '{"t": 0, "state": "Cruising"}\n{"t": 2, "state": "HardBraking"}\n'
    '{"t": 3.5, "state": "AntiLockBrake"}\n{"t": 5, "state": "HardBraking"}\n'
    '{"t": 6, "state": "Stopped"}\n{"t": 20, "end": true}\n'
)
FORMULA_3_1 = (
    "(HardBraking \\rightarrow ((AntiLockBrake \\lor HardBraking) \\until{<10} Stopped))"
    " \\land \\int^{10} HardBraking < 4"
)


@pytest.fixture
def braking(tmp_path):
    path = tmp_path / "braking.jsonl"
    path.write_text(BRAKING, encoding="utf-8")
    return path


def test_eval_at_a_time(rmv, braking):
    assert rmv("eval", "--formula", FORMULA_3_1, "--trace", str(braking)).out == "true\n"
    late = rmv("eval", "--formula", FORMULA_3_1, "--trace", str(braking), "--at", "15")
    assert late.out == "unknown\n"


def test_eval_all_segments_text_and_json(rmv, braking):
    result = rmv("eval", "--formula", FORMULA_3_1, "--trace", str(braking), "--all")
    assert result.out == "[0, 14)  true\n[14, 20)  unknown\n"
    data = json.loads(
        rmv(
            "eval", "--formula", FORMULA_3_1, "--trace", str(braking), "--all", "--format", "json"
        ).out
    )
    assert data["segments"][0] == {
        "from": 0,
        "to": 14,
        "from_closed": True,
        "to_closed": False,
        "verdict": "true",
    }


def test_eval_infix_and_latex_agree(rmv, braking):
    infix = (
        "(HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped)"
        " and duration[10s](HardBraking) < 4s"
    )
    a = rmv("eval", "--formula", infix, "--trace", str(braking), "--all").out
    b = rmv("eval", "--formula", FORMULA_3_1, "--trace", str(braking), "--all").out
    assert a == b


def test_eval_term(rmv, braking):
    assert (
        rmv(
            "eval",
            "--term",
            "--formula",
            "\\int^{10} HardBraking",
            "--trace",
            str(braking),
            "--at",
            "2",
        ).out
        == "2.5\n"
    )
    open_end = rmv(
        "eval",
        "--term",
        "--formula",
        "duration[10s](HardBraking)",
        "--trace",
        str(braking),
        "--at",
        "15",
    )
    assert open_end.out == "unknown (between 0 and 5)\n"


def test_eval_formula_errors_have_positions(rmv, braking):
    result = rmv("eval", "--formula", "eventually Stopped", "--trace", str(braking))
    assert result.code == 1
    assert "error[RMV212]" in result.err and "<formula>:1:1" in result.err
    bad = rmv("eval", "--formula", "a \\untill_{<3} b", "--trace", str(braking))
    assert bad.code == 1 and "did you mean `\\until`?" in bad.err


def test_eval_units_from_the_trace(rmv, tmp_path):
    trace = tmp_path / "ms.jsonl"
    trace.write_text(
        '{"unit": "ms"}\n{"t": 0, "state": "a"}\n{"t": 1500, "state": "b"}\n'
        '{"t": 9000, "end": true}\n'
    )
    # 2s is 2000 ms: b is reached within it; a bare 1000 is in the trace's unit (ms).
    assert rmv("eval", "--formula", "eventually[<2s] b", "--trace", str(trace)).out == "true\n"
    assert (
        rmv("eval", "--formula", "\\eventually_{<1000} b", "--trace", str(trace)).out == "false\n"
    )


def test_csv_traces(rmv, tmp_path):
    trace = tmp_path / "run.csv"
    trace.write_text("# unit: s\nt,props,end\n0,a;b,\n2,b,\n5,,\n8,,true\n")
    assert rmv("eval", "--formula", "a and b", "--trace", str(trace), "--all").out == (
        "[0, 2)  true\n[2, 8)  false\n"
    )


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        ('{"t": 0, "state": "a"}\n{"t": -1, "state": "b"}\n', ":2:2:", "goes backwards"),
        ('{"t": 0, "state": "a"}\n{"t": 0, "state": "b"}\n', ":2:2:", "does not advance"),
        ('{"t": 0, "stat": "a"}\n', ":1:10:", "unknown field `stat`"),
        ('{"t": NaN, "state": "a"}\n', ":1:2:", "times must be finite"),
        ('{"t": 0, "state": "a"}\n{"t": 1, "state": "b"\n', ":2:22:", "not JSON"),
        ('{"t": 0, "props": "a"}\n', ":1:10:", '"props" is a list of strings'),
        (
            '{"t": 0, "state": "a"}\n{"t": 5, "end": true}\n{"t": 6, "state": "b"}\n',
            ":3:1:",
            "after the end",
        ),
        ("t,state\n0,a\nx,b\n", ":3:1:", "must be a number"),
        ("t,colour\n0,a\n", ":1:1:", "no `t` and `state`"),
        ('{"unit": "parsec"}\n', ":1:2:", "unknown unit"),
    ],
)
def test_malformed_traces_are_reported_with_line(tmp_path, text, where, message):
    path = tmp_path / ("t.csv" if text.startswith("t,") else "t.jsonl")
    path.write_text(text, encoding="utf-8")
    with pytest.raises(TraceError) as caught:
        read_trace(str(path), text)
    assert where in str(caught.value) and message in str(caught.value)
    result = rmv_process(["eval", "--formula", "a", "--trace", str(path)])
    assert result.code == 2 and "Traceback" not in result.err and message in result.err


def test_missing_end_is_a_note(rmv, tmp_path):
    path = tmp_path / "open.jsonl"
    path.write_text('{"t": 0, "state": "a"}\n{"t": 3, "state": "b"}\n')
    result = rmv("eval", "--formula", "a", "--trace", str(path), "--all")
    assert result.out == "[0, 3)  true\n"  # known up to the last sample
    assert "no end record" in result.err


# ---- the monitor: lateness, memory, single evaluation time ----


def test_reordering_within_lateness_gives_the_same_verdicts():
    formula = ("until", "<", 5, ("prop", "a"), ("prop", "b"))
    samples = [(0, {"a"}), (2, {"c"}), (3, {"a"}), (6, {"b"}), (9, {"a"}), (12, {"c"})]
    ordered = Monitor(formula)
    ordered.feed(samples)
    ordered.end(15)
    shuffled = Monitor(formula, lateness=3)
    for index in (1, 0, 3, 2, 5, 4):
        shuffled.step(*samples[index])
    shuffled.end(15)
    assert merge(shuffled.verdicts()) == merge(ordered.verdicts())
    assert shuffled.late == []


def test_samples_later_than_the_lateness_are_counted_and_make_input_unknown():
    formula = ("until", "<", 5, ("const", True), ("prop", "b"))
    monitor = Monitor(formula, lateness=1)
    for t, state in [(0, {"a"}), (4, {"a"}), (10, {"a"}), (20, {"a"})]:
        monitor.step(t, state)
    monitor.step(8, {"b"})  # far too late: 20 - 8 > 1
    monitor.end(30)
    assert monitor.late == [8]
    verdicts = merge(monitor.verdicts())
    # the sample at 8 cannot be placed: [8, 10) becomes unknown instead of "a only"
    assert any(v.startswith("unknown") and a <= 8 < b for a, b, _, _, v in verdicts)
    assert not any(v == "false" and a < 8 <= b for a, b, _, _, v in verdicts if a > 3)


def test_memory_is_bounded_by_the_horizon_not_the_trace():
    formula = (
        "and",
        ("until", "<", 100, ("prop", "a"), ("prop", "b")),
        ("cmp", "<", ("dur", 100, ("prop", "a")), ("num", 40)),
    )
    monitor = Monitor(formula)
    sizes = []
    for block in range(20):
        monitor.feed((block * 10_000 + t * 7, {"a"} if t % 3 else {"b"}) for t in range(1400))
        list(monitor.verdicts())
        sizes.append(monitor.memory())
    assert max(sizes[5:]) <= 2 * min(sizes[5:]) + 20
    assert max(sizes) < 400


def test_verdict_at_a_single_time():
    monitor = Monitor(("until", "<=", 3, ("prop", "a"), ("prop", "b")))
    monitor.feed([(0, {"a"}), (3, {"b"}), (4, {"a"})])
    assert monitor.verdict_at(0) == "true"
    assert monitor.verdict_at(Fraction(7, 2)) == "true"
    assert monitor.verdict_at(4) == "unknown"
