"""`rmv eval`'s values from the reference evaluator (a verdict before the trace's first
sample, `--term`): it reads only the part of the trace within the formula's horizons
around the time asked, and every value is the whole trace's."""

from __future__ import annotations

import itertools
from fractions import Fraction

from test_eval import STREAM_FORMULAS, _random_trace

from rmvdsl.logic.trace_lines import read_trace

HORIZON_FORMULAS = [
    *STREAM_FORMULAS,
    "once[<=2s] (a until[<=1.5s] b)",
    "(a since[<1s] eventually[<=2s] c) or always[<=0.5s] b",
    "duration[1.5s](a until[<1s] b) > 0.25s",
    "a since b",
]
HORIZON_TERMS = ["duration[3s](a)", "2 * duration[1s](eventually[<=1s] b) + duration[0.5s](c)"]


def test_a_value_reads_the_trace_only_within_its_horizons(tmp_path):
    """`rmv eval --at` before the first sample, and `--term`, give the reference
    evaluator the part of the trace within the formula's horizons around that time
    (`evaluate.reference_part`; a million samples read whole took a minute): every
    value is the whole trace's, at times before, at and between samples."""
    import io
    import random as random_module

    from rmvdsl.logic import evaluate as ev
    from rmvdsl.logic.traces import TraceStream

    random = random_module.Random(7)
    compared = cut = 0
    for case in range(40):
        text = _random_trace(random)
        path = str(tmp_path / f"t{case}.jsonl")
        whole = read_trace(path, text)
        times = whole.times
        probes = {times[0] - 1, times[0], times[-1] + 1, *random.sample(times, min(4, len(times)))}
        probes |= {(a + b) / 2 for a, b in itertools.pairwise(times[:4])}
        for written in [*HORIZON_FORMULAS, *HORIZON_TERMS]:
            node, _ = ev.parse(written, "auto", written in HORIZON_TERMS)
            compiled, problems = ev.compile_or_diagnose(
                node, whole.unit_seconds, whole.unit, [], written
            )
            assert compiled is not None, problems
            for at in sorted(probes):
                stream = TraceStream(path, io.BytesIO(text.encode()))
                part = ev.reference_part(stream, stream.changes(), at, compiled)
                cut += part.times[0] > times[0] or part.end < whole.end
                if written in HORIZON_TERMS:
                    expected, got = ev.term_at(compiled, whole, at), ev.term_at(compiled, part, at)
                else:
                    expected = ev.reference_verdict(compiled, whole, at)
                    got = ev.reference_verdict(compiled, part, at)
                assert got == expected, (text, written, at)
                compared += 1
    assert compared > 2000 and cut > compared // 3  # most probes read a part


def test_eval_before_the_first_sample_and_a_term_read_what_they_need(rmv, tmp_path):
    """On a long trace the value before its first sample and a term are the whole
    trace's (the reference evaluator's over all of it)."""
    lines = ['{"unit": "s"}']
    for i in range(3000):
        lines.append(f'{{"t": {100 + i / 10}, "state": "{"ab"[i // 7 % 2]}"}}')
    text = "\n".join(lines) + "\n"
    path = tmp_path / "long.jsonl"
    path.write_text(text, encoding="utf-8")
    from rmvdsl.logic import evaluate as ev
    from rmvdsl.runtime.values import exact_text

    whole = read_trace(str(path), text)
    for formula, at in (("eventually[<=100.5s] b", "0"), ("a until[<101s] b", "-1")):
        node, _ = ev.parse(formula, "auto", False)
        compiled, _ = ev.compile_or_diagnose(node, whole.unit_seconds, whole.unit, [], formula)
        expected = ev.reference_verdict(compiled, whole, Fraction(at))
        got = rmv("eval", "--formula", formula, "--trace", str(path), "--at", at)
        assert (got.code, got.out) == (0, expected + "\n"), got.err
    term = rmv(
        "eval", "--term", "--formula", "duration[2s](b)", "--trace", str(path), "--at", "150"
    )
    node, _ = ev.parse("duration[2s](b)", "auto", True)
    compiled, _ = ev.compile_or_diagnose(node, whole.unit_seconds, whole.unit, [], "")
    low, high = ev.term_at(compiled, whole, Fraction(150))
    assert low == high and term.out == exact_text(low) + "\n", term.err
