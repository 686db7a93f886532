"""`rmv eval`, trace files, lateness, and the monitor's bounded memory."""

from __future__ import annotations

import json
import math
import sys
from fractions import Fraction

import pytest
from conftest import CountingStream, rmv_process

from rmvdsl.logic.trace_lines import TraceError, read_trace
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


def test_eval_reads_with_the_collector_set_for_streams_and_restores_it(rmv, braking, monkeypatch):
    import gc

    from rmvdsl.commands import formula
    from rmvdsl.util.collection import YOUNG

    seen = []
    original = formula._eval_output

    def watched(*args):
        seen.append(gc.get_threshold()[0])
        return original(*args)

    monkeypatch.setattr(formula, "_eval_output", watched)
    before = gc.get_threshold()
    assert rmv("eval", "--formula", FORMULA_3_1, "--trace", str(braking)).out == "true\n"
    assert seen == [YOUNG] and gc.get_threshold() == before


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
        # a number is not a name (the reader keeps it as its text: NaN was `NaN`)
        ('{"t": 0, "state": NaN}\n', ":1:10:", '"state" is a string'),
        ('{"t": 0, "state": 5}\n', ":1:10:", '"state" is a string'),
        ('{"t": 0, "props": ["a", Infinity]}\n', ":1:10:", '"props" is a list of strings'),
        ('{"t": 0, "state": "a b"}\n', ":1:10:", "`a b` is not a proposition name"),
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


# ---- the streaming reader: the same answers as the whole trace, any chunking ----

STREAM_FORMULAS = [
    FORMULA_3_1,
    "a until[<2.5s] b",
    "a -> once[<=1.5s] b",
    "eventually[<1s] (a and not b)",
    "2 * duration[3s](a) > duration[2s](b) + 0.5s",
]


def _random_trace(random) -> str:
    """JSON Lines mixing the common shape with every other one: props, string and
    quotient times, spaces, a unit line, blank lines, and times that go up by tiny
    or large steps."""
    lines = [random.choice(['{"unit": "ms"}', "", '{"unit": "s"}'])]
    t = Fraction(random.randint(-5, 5), random.choice([1, 10, 100]))
    for _ in range(random.randint(1, 60)):
        t += Fraction(random.randint(1, 40), random.choice([1, 10, 1000, 3]))
        name = random.choice(["a", "b", "c"])
        text = _decimal(t) if (t * 1000).denominator == 1 else f'"{t.numerator}/{t.denominator}"'
        shape = random.randrange(5)
        if shape == 0:
            props = ", ".join(f'"{p}"' for p in sorted({name, random.choice("abc")}))
            lines.append(f'{{"t": {text}, "props": [{props}]}}')
        elif shape == 1:
            lines.append(f'  {{ "t" : {text} ,"state":"{name}" }} ')
        else:
            lines += [""] * (shape == 2) + [f'{{"t": {text}, "state": "{name}"}}']
    if random.random() < 0.7:
        lines.append(f'{{"t": {_decimal(t + 5)}, "end": true}}')
    return "\n".join(lines) + random.choice(["\n", ""])


def _decimal(t: Fraction) -> str:
    from rmvdsl.lang.numbers import decimal

    return decimal(t)


def _whole(formula: str, path, text: str) -> str:
    """What `rmv eval --all --format json` wrote before it streamed: the monitor over
    the trace read whole, times in the trace's unit."""
    from rmvdsl.logic import evaluate as ev

    trace = read_trace(str(path), text)
    node, _ = ev.parse(formula, "auto", False)
    compiled, problems = ev.compile_or_diagnose(node, trace.unit_seconds, trace.unit, [], formula)
    assert compiled is not None, problems
    result = ev.run(compiled, trace)
    return ev.as_json(
        {
            "segments": [ev.segment_json(s) for s in result.segments],
            "beyond": [ev.segment_json(s) for s in result.beyond],
            "horizon": result.horizon,
            "memory": {"held": result.memory, "bound": result.bound()},
        }
    )


@pytest.mark.parametrize("chunk", [1 << 20, 7, 64])
def test_streamed_eval_equals_the_whole_trace(rmv, tmp_path, monkeypatch, chunk):
    import random as random_module

    from rmvdsl.logic import traces

    monkeypatch.setattr(traces, "CHUNK", chunk)
    random = random_module.Random(chunk)
    for case in range(25):
        text = _random_trace(random)
        path = tmp_path / f"t{case}.jsonl"
        path.write_text(text, encoding="utf-8")
        for formula in STREAM_FORMULAS:
            got = rmv(
                "eval", "--formula", formula, "--trace", str(path), "--all", "--format", "json"
            )
            expected = json.loads(_whole(formula, path, text))
            streamed = json.loads(got.out)
            # held breakpoints depend on how the input was batched, nothing else does
            expected["memory"].pop("held"), streamed["memory"].pop("held")
            assert streamed == expected, (text, formula)
            lines = rmv("eval", "--formula", formula, "--trace", str(path), "--all").out
            segments = _segments_of(got.out)
            assert lines.splitlines()[: len(segments)] == segments, (text, formula)
            probe = random.choice([s["from"] for s in expected["segments"]] or [0])
            at = rmv("eval", "--formula", formula, "--trace", str(path), "--at", str(probe))
            assert at.code == 0 and at.out.strip() in ("true", "false", "unknown")


def _segments_of(payload: str) -> list[str]:
    """The text lines of the segments of `rmv eval --all --format json`'s output, as
    `segment_text` writes exact times."""
    from rmvdsl.lang.numbers import exact_or_quotient
    from rmvdsl.logic.evaluate import segment_text

    def time(value):
        return math.inf if value is None else exact_or_quotient(str(value))

    segments = json.loads(payload, parse_float=Fraction, parse_int=Fraction)["segments"]
    return [
        segment_text(
            (time(s["from"]), time(s["to"]), s["from_closed"], s["to_closed"], s["verdict"])
        )
        for s in segments
    ]


@pytest.mark.parametrize("form", ["text", "json"])
def test_all_segments_are_written_in_batches_and_at_once_to_a_terminal(tmp_path, monkeypatch, form):
    """`--all` wrote each segment with a write of its own (300,000 system calls for
    a trace of as many changes). It writes batches now, the same text, also up to a
    bad line that ends the run; a terminal still gets each line as it is decided."""
    from rmvdsl.cli import main
    from rmvdsl.util.batched import Batched

    path = tmp_path / "t.jsonl"
    rows = "".join(f'{{"t": {k}, "state": "{"ab"[k % 2]}"}}\n' for k in range(20_000))
    outputs = {}
    for ending, code in (('{"t": 20000, "end": true}\n', 0), ('{"t": 1}\n', 2)):
        path.write_text(rows + ending, encoding="utf-8")
        for terminal in (False, True):
            stream = CountingStream(terminal)
            monkeypatch.setattr(sys, "stdout", stream)
            assert main(["eval", "--formula", "a", "--trace", str(path), "--all",
                         "--format", form]) == code  # fmt: skip
            outputs[code, terminal] = stream
        batched, live = outputs[code, False], outputs[code, True]
        assert "".join(batched.parts) == "".join(live.parts)
        written = "".join(batched.parts)
        segments = written.count('"from"') if form == "json" else written.count("\n")
        assert segments > (19_000 if code == 0 else 10_000)  # (read ahead: not all)
        assert batched.writes <= segments // Batched.SIZE + 3
        assert live.writes >= segments - 3
    # the run ended by the bad line wrote what it had decided before it
    whole, cut = ("".join(outputs[c, False].parts) for c in (0, 2))
    assert whole.startswith(cut)


def test_streamed_json_is_the_whole_payloads_text(rmv, braking):
    """Written a segment at a time, the JSON is the text `as_json` gives the whole."""
    out = rmv(
        "eval", "--formula", FORMULA_3_1, "--trace", str(braking), "--all", "--format", "json"
    )
    assert out.out == _whole(FORMULA_3_1, braking, BRAKING)


def test_fast_lines_report_their_own_line_and_ties_are_exact(rmv, tmp_path, monkeypatch):
    from rmvdsl.logic import traces

    monkeypatch.setattr(traces, "CHUNK", 40)
    lines = [f'{{"t": {t}, "state": "{"ab"[t % 2]}"}}' for t in range(30)]
    lines[17] = '{"t": 3, "state": "a"}'
    path = tmp_path / "back.jsonl"
    path.write_text("\n".join(lines) + "\n")
    result = rmv("eval", "--formula", "a", "--trace", str(path), "--all")
    assert result.code == 2 and ":18:2:" in result.err and "goes backwards" in result.err
    # equal as floats, different as decimals: the second is later, exactly
    tie = tmp_path / "tie.jsonl"
    tie.write_text(
        '{"t": 123456789012345.000000001, "state": "a"}\n'
        '{"t": 123456789012345.000000002, "state": "b"}\n'
        '{"t": 123456789012345.000000002, "state": "a"}\n'
    )
    result = rmv("eval", "--formula", "a", "--trace", str(tie), "--all")
    assert result.code == 2 and ":3:2:" in result.err and "does not advance" in result.err


def test_csv_common_shape_streams(rmv, tmp_path, monkeypatch):
    from rmvdsl.logic import traces

    monkeypatch.setattr(traces, "CHUNK", 16)
    path = tmp_path / "run.csv"
    path.write_text("# unit: ms\nt,state\n0,a\n500,b\n1500,a\n2000,b\n")
    result = rmv("eval", "--formula", "a until[<1s] b", "--trace", str(path), "--all")
    assert result.out == "[0, 1500)  true\n[1500, 2000)  unknown\n"  # b at 2000: not yet known
    assert "no end record" in result.err


def test_stream_reads_crlf_a_byte_order_mark_and_reports_bad_bytes(rmv, tmp_path, monkeypatch):
    from rmvdsl.logic import traces

    monkeypatch.setattr(traces, "CHUNK", 32)
    crlf = tmp_path / "windows.jsonl"
    crlf.write_bytes(("\ufeff" + BRAKING.replace("\n", "\r\n")).encode("utf-8"))
    result = rmv("eval", "--formula", FORMULA_3_1, "--trace", str(crlf), "--all")
    assert result.out == "[0, 14)  true\n[14, 20)  unknown\n", result.err
    props = tmp_path / "props.csv"
    props.write_bytes(b"t,props\r\n0,a;b\r\n2,b\r\n5,\r\n8,a\r\n")
    assert rmv("eval", "--formula", "a", "--trace", str(props), "--all").out == (
        "[0, 2)  true\n[2, 8)  false\n"
    )
    bad = tmp_path / "latin1.jsonl"
    bad.write_bytes(b'{"t": 0, "state": "a"}\n{"t": 1, "state": "b"}\n{"t": 2, "state": "\xe9"}\n')
    result = rmv("eval", "--formula", "a", "--trace", str(bad))
    assert result.code == 2 and ":3:20:" in result.err and "not UTF-8" in result.err


def test_any_key_order_spacing_or_props_list_reads_the_same(rmv, tmp_path):
    """The common content written any way JSON allows (keys swapped, spaces, a
    `props` list, a few lines only through the full reader) gives the same segments:
    the fast reading is not tied to one key order."""
    import random

    rng = random.Random(5)
    samples = [(k / 4, rng.choice("ABC")) for k in range(2000)]
    forms = {
        "usual": lambda t, s: f'{{"t": {t}, "state": "{s}"}}',
        "swapped": lambda t, s: f'{{"state": "{s}", "t": {t}}}',
        "tight": lambda t, s: f'{{"t":{t},"props":["{s}"]}}',
        # a props list naming one twice, spaces everywhere, and every 7th line
        # with a time the fast reading leaves to the full reader (an exponent)
        "mixed": lambda t, s: (
            f'{{ "props" : ["{s}", "{s}"] , "t" : {t} }}' if int(t * 4) % 7 else
            f'{{"state": "{s}", "t": {t * 100}e-2}}'
        ),
    }  # fmt: skip
    outputs = {}
    for name, form in forms.items():
        path = tmp_path / f"{name}.jsonl"
        path.write_text(
            "".join(form(t, s) + "\n" for t, s in samples) + '{"t": 600, "end": true}\n'
        )
        run = rmv("eval", "--formula", "A -> eventually[<=2] B", "--trace", str(path), "--all")
        assert run.code in (0, 1), run.err
        outputs[name] = run.out
    assert len(set(outputs.values())) == 1, outputs


def test_a_bad_line_among_fast_ones_is_reported_at_its_place(rmv, tmp_path):
    path = tmp_path / "t.jsonl"
    lines = [f'{{"state": "A", "t": {k}}}' for k in range(10)]
    for bad, message in [
        ('{"state": "A B", "t": 6}', "`A B` is not a proposition name"),
        ('{"state": "A", "t": true}', "`t` must be a number"),
        ('{"state": "A", "t": 5}', "does not advance"),
        ('{"state": "A", "t": 6, "end": true}', "an end record has no state"),
        ('{"t": 6, "stat": "A"}', "unknown field `stat`"),
    ]:
        path.write_text("\n".join([*lines[:6], bad, *lines[7:]]) + "\n")
        run = rmv("eval", "--formula", "A", "--trace", str(path), "--all")
        assert run.code == 2 and ":7:" in run.err and message in run.err, run.err


def test_any_key_order_and_extra_fields_read_alike_the_first_extra_noted(rmv, tmp_path):
    """What a logger writes: keys in any order, its own fields beside them, ints and
    floats mixed; the same segments as the plain form, and one note."""
    plain, varied = tmp_path / "plain.jsonl", tmp_path / "varied.jsonl"
    rows = [(k / 4, "AB"[k // 3 % 2]) for k in range(40)]
    plain.write_text("".join(f'{{"t": {t}, "state": "{s}"}}\n' for t, s in rows))
    varied.write_text("".join(
        f'{{"state": "{s}", "seq": {k}, "t": {int(t) if t == int(t) else t}}}\n'
        if k % 2 else f'{{"t": {t}, "state": "{s}"}}\n'
        for k, (t, s) in enumerate(rows)
    ))  # fmt: skip
    runs = [
        rmv("eval", "--formula", "A until[<2s] B", "--trace", str(p), "--all", "--format", "json")
        for p in (plain, varied)
    ]
    assert runs[0].code == runs[1].code == 0 and runs[0].out == runs[1].out, runs
    assert "varied.jsonl:2: fields other than t, state, props and end are ignored" in runs[1].err
    assert "(the first: `seq`)" in runs[1].err and "ignored" not in runs[0].err
