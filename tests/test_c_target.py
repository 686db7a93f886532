"""The C target (docs/c.md): its monitors, compiled with -Werror and with the
address and undefined-behaviour sanitizers, give the Python runtime's verdict
segments on 10,000 random formulas x traces, on the example over its recordings
and on random property inputs; input faster than the memory is sized for is
unknown, never wrong. tests/test_c_builds.py tests the builds themselves."""

from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
from concurrent.futures import ProcessPoolExecutor
from fractions import Fraction
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from c_harness import (
    compile_driver,
    compiler,
    end_line,
    monitor_segments,
    run_driver,
    sample_line,
    segments_by_property,
    write,
)

from rmvdsl.runtime.properties import PropertyMonitor
from rmvdsl.runtime.rmtld3 import merge
from rmvdsl.targets.c.generate import files, laid_out
from rmvdsl.targets.c.model import compile_formula, sized

pytestmark = pytest.mark.skipif(compiler() is None, reason="needs a C compiler (gcc)")

ROOT = Path(__file__).resolve().parent.parent
CASES = int(os.environ.get("RMV_C_CASES", "10000"))
BATCH_CASES = 1000
NS = 1_000_000_000
START = Fraction("1700000000.123456789")


# ---- random formulas and traces (the generators of test_monitor_equivalence,
# with the comparisons the C target compiles: one duration against a constant) ----


def random_formula(rng: random.Random, names: list[str], depth: int) -> Any:
    leaf_only = depth == 0 or rng.random() < 0.2
    if leaf_only:
        if rng.random() < 0.85:
            return ("prop", rng.choice(names))
        return ("const", rng.random() < 0.5)
    kind = rng.choice(["not", "and", "or", "until", "since", "until", "since", "cmp"])
    sub = lambda: random_formula(rng, names, depth - 1)  # noqa: E731
    if kind == "not":
        return ("not", sub())
    if kind in ("and", "or"):
        return (kind, sub(), sub())
    if kind in ("until", "since"):
        left = ("const", True) if rng.random() < 0.3 else sub()
        if kind == "since" and rng.random() < 0.25:  # no bound: once, historically, since
            return (kind, "<=", None, left, sub())
        return (kind, rng.choice(["<", "<=", "="]), random_bound(rng), left, sub())
    duration = ("dur", random_bound(rng, positive=True), sub())
    constant = ("num", Fraction(rng.randint(0, 10)))
    shape = rng.randrange(5)
    term = [duration, ("add", duration, ("num", Fraction(rng.randint(-3, 3)))),
            ("sub", ("num", Fraction(rng.randint(0, 10))), duration),
            ("mul", duration, ("num", Fraction(rng.choice([1, -1])))), duration][shape]  # fmt: skip
    op = rng.choice(["<", "<=", ">", ">=", "==", "!="])
    return ("cmp", op, term, constant) if rng.random() < 0.5 else ("cmp", op, constant, term)


def random_bound(rng: random.Random, positive: bool = False) -> Fraction:
    high = 12 if rng.random() < 0.6 else 100
    return Fraction(rng.randint(1 if positive else 0, high))


def random_trace(
    rng: random.Random, names: list[str]
) -> list[tuple[Fraction, frozenset, frozenset]]:
    """Samples (time, state, pulses): 1-8 changes 1-8 apart, some with pulses, from
    a start that is no whole number of the sampling periods (ticks are at multiples
    of the period from time 0, not from the first sample)."""
    t, samples = START, []
    for _ in range(rng.randint(1, 8)):
        state = frozenset(n for n in names if rng.random() < 0.5)
        pulses = frozenset(n for n in names if rng.random() < 0.1)
        samples.append((t, state, pulses))
        t += rng.randint(1, 8)
    return samples


def python_segments(
    formula: Any, trace: list, end: Fraction, period_ns: int, names: list[str]
) -> list:
    """The verdicts the Python runtime gives: the monitor fed every sample (as
    `rmv eval` does), or the property monitor sampling at a rate (as `rmv replay`)."""
    if not period_ns:
        return monitor_segments(formula, trace, end)
    prop = SimpleNamespace(
        formula=formula, propositions=tuple(names), trigger="always",
        rate=Fraction(NS, period_ns), horizon_future=0, horizon_past=0,
    )  # fmt: skip
    first_time = trace[0][0]
    monitor = PropertyMonitor(prop, int(first_time * NS), frozenset())  # type: ignore[arg-type]
    held: frozenset = frozenset()
    for t, state, pulses in trace:
        changes = [(n, True) for n in state - held] + [(n, False) for n in held - state]
        for n in pulses - state:
            changes += [(n, True), (n, False)]
        monitor.instant(int(t * NS), changes)
        held = state
    monitor.end(int(end * NS))
    return merge(monitor.verdicts())


def renamed(formula: Any, prefix: str) -> Any:
    if formula[0] == "prop":
        return ("prop", prefix + formula[1])
    return tuple(renamed(part, prefix) if isinstance(part, tuple) else part for part in formula)


def run_batch(seed: int, count: int, folder: Path) -> list[str]:
    """`count` random cases as the properties of one system (each over its own
    propositions), compiled once with the sanitizers; the mismatches found."""
    rng = random.Random(seed)
    cases, compiled = [], []
    for k in range(count):
        names = [f"c{k}_{n}" for n in "abc"]
        formula = renamed(random_formula(rng, ["a", "b", "c"], rng.randint(1, 5)), f"c{k}_")
        trace = random_trace(rng, names)
        period = rng.choice([0, 0, 0, NS // 2, NS])  # every change, or sampled at 2 Hz / 1 Hz
        changes = len(trace) * 2 + 2
        compiled.append((f"case{k}", repr(formula), sized(compile_formula(formula), changes),
                         2 * period))  # fmt: skip
        cases.append((formula, trace, period, names))
    end = max(trace[-1][0] for _, trace, _, _ in cases) + rng.randint(1, 8)
    write(files(laid_out("batch", compiled)), folder)
    program = compile_driver(folder, sanitize=True)
    stream: dict[Fraction, tuple[set, set]] = {}
    for _, trace, _, _ in cases:
        for t, state, pulses in trace:
            holds, pulsed = stream.setdefault(t, (set(), set()))
            holds.update(state)
            pulsed.update(pulses)
    # a case's state holds until its next sample: carry it through the others' times
    current: dict[int, frozenset] = {}
    lines = []
    for t in sorted(stream):
        for k, (_, trace, _, _) in enumerate(cases):
            for when, state, _ in trace:
                if when == t:
                    current[k] = state
        holds = set().union(*current.values()) if current else set()
        lines.append(sample_line(t, holds, stream[t][1]))
    lines.append(end_line(end))
    status, records, errors = run_driver(program, lines)
    assert status in (0, 1), errors
    got = segments_by_property(records)
    assert not [r for r in records if r.get("kind") == "counter"], "a monitor overflowed its pools"
    mismatches = []
    for k, (formula, trace, period, names) in enumerate(cases):
        expected = python_segments(formula, trace, end, period, names)
        if got.get(f"case{k}", []) != expected:
            mismatches.append(
                f"seed {seed} case {k}: {formula!r} over {trace!r} (period {period})"
                f"\n  python: {expected}\n  c:      {got.get(f'case{k}')}"
            )
    return mismatches


def test_random_formulas_and_traces_equal_the_python_runtime(tmp_path: Path) -> None:
    """Batches in two processes: each computes its Python verdicts while the other
    compiles or runs its C."""
    batches = -(-CASES // BATCH_CASES)
    counts = [min(BATCH_CASES, CASES - b * BATCH_CASES) for b in range(batches)]
    with ProcessPoolExecutor(max_workers=2) as pool:
        found = pool.map(run_batch, [1000 + b for b in range(batches)], counts,
                         [tmp_path / f"b{b}" for b in range(batches)])  # fmt: skip
        mismatches = [m for batch in found for m in batch]
    assert not mismatches, "\n".join(mismatches[:5])


def spec_of(path: Path) -> Any:
    from rmvdsl.check import check
    from rmvdsl.ir import lower

    result = check(str(path))
    assert not result.errors
    return lower(result)


RECORDINGS = sorted((ROOT / "examples" / "carla" / "recordings").iterdir())


# gcc over every recording; clang (also -Werror clean, and sanitized) over one.
COMPILED = [(r, "gcc") for r in RECORDINGS] + [(RECORDINGS[0], "clang")]


@pytest.mark.parametrize(("recording", "cc"), COMPILED, ids=lambda p: getattr(p, "name", p))
def test_the_example_over_its_recordings_equals_rmv_replay(
    recording: Path, cc: str, tmp_path: Path
) -> None:
    """The runtime's property inputs during `rmv replay`, fed to the C monitors of
    the same spec (sanitized), print `rmv replay --format jsonl`'s verdict lines,
    byte for byte, compiled by gcc and by clang."""
    from c_harness import property_inputs

    from rmvdsl.targets.c.generate import system_of

    spec = spec_of(ROOT / "examples" / "carla" / "abs.rmv")
    lines, expected = property_inputs(spec, [recording])
    write(files(system_of(spec)), tmp_path)
    assert shutil.which(cc), f"{cc} is needed (.ci/run installs it)"
    program = compile_driver(tmp_path, sanitize=True, cc=cc)
    done = subprocess.run([str(program)], input="\n".join(lines) + "\n", capture_output=True,
                          text=True)  # fmt: skip
    printed = [line for line in done.stdout.splitlines() if '"kind": "verdict"' in line]
    assert sorted(printed) == sorted(expected), done.stderr
    assert {json.loads(line)["property"] for line in printed} == {p.name for p in spec.properties}
    assert done.returncode == (1 if any('"verdict": "false"' in line for line in printed) else 0)


EXAMPLES = [
    ROOT / "examples" / "carla" / "abs.rmv",
    ROOT / "examples" / "gazebo" / "prius_platoon.rmv",
]


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_example_over_random_samples_equals_the_property_monitors(
    path: Path, tmp_path: Path
) -> None:
    """Random instants over each example's propositions (states changing every
    0-400 ms, pulses now and then), through the runtime's property monitors and
    through the C build of the same spec."""
    assert_random_instants_agree(spec_of(path), None, 1_000_000, tmp_path)


def test_a_property_without_rate_is_built_for_max_rate(tmp_path: Path) -> None:
    """A property monitored at every change (no `rate`), built with --max-rate 10Hz
    and given changes at most 10 a second: the property monitor's verdicts."""
    spec = tmp_path / "p.rmv"
    spec.write_text(
        'system p\ntopic t: std_msgs/Float64 = "/t"\nvar X = t.data\n'
        "event A when X > 1\nevent B when X > 2\n"
        "property P: A -> eventually[<=1s] B\n"
        "property Q: duration[2s](A) - 1s < 0.5s\n"
    )
    assert_random_instants_agree(spec_of(spec), Fraction(10), 100_000_000, tmp_path / "out")


def assert_random_instants_agree(
    spec: Any, max_rate: Fraction | None, grain: int, out: Path
) -> None:
    """3,000 random instants `grain` ns apart or more (0-400 ms), the same through
    the property monitors and the C build."""
    from rmvdsl.targets.c.generate import system_of

    names = sorted({n for p in spec.properties for n in (*p.propositions, p.trigger)} - {"always"})
    rng = random.Random(7)
    start = 1_700_000_000 * NS
    monitors = [PropertyMonitor(p, start, frozenset()) for p in spec.properties]
    truth: set[str] = set()
    lines = [sample_line(Fraction(start, NS), truth)]
    time = start
    for _ in range(3000):
        time += rng.randrange(grain, 400_000_000, grain)
        flips = {n for n in names if rng.random() < 0.15}
        pulses = {n for n in names if rng.random() < 0.03} - truth - flips
        changes = [(n, n not in truth) for n in sorted(flips)]
        changes += [c for n in sorted(pulses) for c in ((n, True), (n, False))]
        truth ^= flips
        for monitor in monitors:
            monitor.instant(time, changes)
        lines.append(sample_line(Fraction(time, NS), truth, pulses))
    end = time + 3 * NS
    for monitor in monitors:
        monitor.end(end)
    lines.append(end_line(Fraction(end, NS)))
    expected = {p.name: merge(m.verdicts()) for p, m in zip(spec.properties, monitors, strict=True)}
    write(files(system_of(spec, max_rate)), out)
    _, records, errors = run_driver(compile_driver(out, sanitize=True), lines)
    assert segments_by_property(records) == expected, errors
    assert any(s[4] == "false" for v in expected.values() for s in v)  # the data decides something


def test_triggered_properties_equal_the_property_monitors(tmp_path: Path) -> None:
    """abs.rmv's properties, each triggered by a state or an event that comes and
    goes (and pulses while the property is stopped), over random instants: the
    property monitors' verdicts, activation by activation."""
    import dataclasses

    spec = spec_of(ROOT / "examples" / "carla" / "abs.rmv")
    triggers = ["Cruising", "HardBraking", "StopReached", "AntiLockBrake"]
    properties = tuple(
        dataclasses.replace(p, trigger=triggers[k % len(triggers)])
        for k, p in enumerate(spec.properties)
    )
    assert_random_instants_agree(dataclasses.replace(spec, properties=properties), None,
                                 1_000_000, tmp_path)  # fmt: skip


def test_input_faster_than_the_rate_is_counted_and_unknown_never_wrong(tmp_path: Path) -> None:
    """Pools sized for 1 change in a 4 s stretch (eventually[<=1]) get 400: the
    monitor overflows, counts it, says unknown over what it lost and starts again;
    what it does say is what the Python monitor says there."""
    formula = ("until", "<=", Fraction(1), ("const", True), ("prop", "a"))
    write(
        files(laid_out("fast", [("P", "eventually", sized(compile_formula(formula), 1), 0)])),
        tmp_path,
    )
    samples = [(Fraction(k, 100), frozenset({"a"} if k % 2 else ())) for k in range(400)]
    lines = [sample_line(t, s) for t, s in samples] + [end_line(Fraction(5))]
    status, records, errors = run_driver(compile_driver(tmp_path, sanitize=True), lines)
    assert status in (0, 1), errors
    counters = [r for r in records if r["kind"] == "counter"]
    assert counters and counters[0]["value"] > 0 and counters[0]["property"] == "P"
    got = segments_by_property(records)["P"]
    assert any(s[4] == "unknown" and s[1] < 4 for s in got)
    python = monitor_segments(formula, samples, Fraction(5))
    for a, b, _, _, value in got:
        if value != "unknown":
            assert all(v == value for x, y, _, _, v in python if x < b and a < y)
