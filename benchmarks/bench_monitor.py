"""The online RMTLD3 monitor beside rtamt and reelay, like for like, answers checked.

A braking controller sampled at 100 Hz: four states (Cruising, HardBraking,
AntiLockBrake, Stopped), each held a random 0.05-3 s (seeded); times are 10 ms ticks.
Two sections, each giving every tool the same input, the same semantics and the
same number of repeats (best of --repeat):

- per sample (discrete time): every tool is fed every one of --samples samples.
  rmvdsl's monitor (whose feed skips a sample that repeats the state), rtamt's
  and reelay's discrete monitors (past time only: the past mirror; rtamt's
  pastified future formulas answer wrongly, see RTAMT_DISCRETE) and a loop for
  `HardBraking -> eventually[<=10s] Stopped`. Verdicts are compared at every sample
  the tools all decide.
- per change (dense time): every tool is fed the change points of --dense-samples
  samples. rmvdsl's monitor, reelay's dense monitor and rtamt's dense monitor
  (both past time only: the past mirror). rtamt's dense signals are piecewise
  linear, so each piece is given as two samples, at its start and 0.001 tick before
  the next; its verdicts are compared away from those 0.001-tick ramps. Verdicts
  are compared on every open interval between the tools' change points.

Formulas no other tool can monitor (durations: formula 3.1) are checked against the
reference evaluator (rmvdsl.logic.reference) on a prefix. A disagreement stops the
benchmark (exit status 1) before any speed is printed.

    python benchmarks/bench_monitor.py                 # 50,000 / 1,000,000 samples
    python benchmarks/bench_monitor.py --json benchmarks/results/monitor.json
"""

from __future__ import annotations

import argparse
import bisect
import gc
import itertools
import json
import math
import random
import sys
import time
from collections import deque
from collections.abc import Callable, Iterable
from fractions import Fraction
from functools import partial
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rmvdsl.grammar.formula_parser import parse_formula
from rmvdsl.logic.compile import compile_formula
from rmvdsl.logic.reference import Reference, Trace
from rmvdsl.runtime.rmtld3 import Monitor, Segment, merge

try:  # imported before any clock starts: their first import is not their speed
    import reelay
except ImportError:
    reelay = None
try:
    import rtamt
except ImportError:
    rtamt = None

STATES = ("Cruising", "HardBraking", "AntiLockBrake", "Stopped")
TICK = Fraction(1, 100)  # seconds per tick
RAMP = 0.001  # ticks: rtamt's dense input holds a piece until this long before the next

FORMULAS = {
    "formula 3.1": "(HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped) "
    "and duration[10s](HardBraking) < 4s",
    "until part": "HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped",
    "eventually": "HardBraking -> eventually[<=10s] Stopped",
    "past mirror": "Stopped -> once[<=10s] HardBraking",
}
# rtamt's discrete formulas: past time only. Its pastify (what makes a future formula
# online) mis-times a boolean combination of a temporal and a non-temporal part:
# `(r < 0) or eventually[0:3] (q >= 0)` over 12 samples answers -1 for t = 3, where r
# is negative (docs/semantics.md, "Beside other monitors").
RTAMT_DISCRETE = {"past mirror": "(st >= 0) implies (once[0:1000] (hb >= 0))"}
RTAMT_DENSE = {"past mirror": "(st >= 0) implies (once[0:1000] (hb >= 0))"}
REELAY = {"past mirror": "{Stopped} -> once[0:1000] {HardBraking}"}
VARIABLES = {"hb": "HardBraking", "ab": "AntiLockBrake", "st": "Stopped"}

Samples = list[tuple[int, str]]
Steps = tuple[list[float], list[bool], float]  # change times, values from each, decided up to


class Disagreement(Exception):
    pass


def generate(samples: int, seed: int = 2019) -> Samples:
    rng = random.Random(seed)
    trace: Samples = []
    state = "Cruising"
    tick = 0
    while tick < samples:
        hold = rng.randint(5, 300)  # 0.05 s to 3 s
        for _ in range(min(hold, samples - tick)):
            trace.append((tick, state))
            tick += 1
        state = rng.choice([s for s in STATES if s != state])
    return trace


def change_points(trace: Samples) -> Samples:
    return [trace[0], *(b for a, b in itertools.pairwise(trace) if a[1] != b[1])]


def compiled(name: str) -> Any:
    node, diagnostics = parse_formula(FORMULAS[name], "rmv")
    assert node is not None, diagnostics
    return compile_formula(node, unit=TICK)


def best(repeat: int, make: Callable[[], Any], run: Callable[[Any], Any]) -> tuple[float, Any]:
    """The fastest of `repeat` runs, each on a monitor made before its clock starts."""
    times, result = [], None
    for _ in range(repeat):
        monitor = make()
        gc.collect()
        start = time.perf_counter()
        result = run(monitor)
        times.append(time.perf_counter() - start)
    return min(times), result


def timed(
    row: dict[str, Any],
    tool: str,
    count: int,
    repeat: int,
    make: Callable[[], Any],
    run: Callable[[Any], Any],
) -> Any:
    """`best` of one tool, its rate (count per second) put in `row`; its output."""
    seconds, out = best(repeat, make, run)
    row[tool] = count / seconds
    return out


def partial_run(function: Callable[[Any, Any], Any], data: Any) -> Callable[[Any], Any]:
    """function(monitor, data), for a monitor made before the clock starts."""
    return lambda monitor: function(monitor, data)


# ---- the tools: monitors made and input prepared before the clock starts ----


def fed(monitor: Monitor, samples: list[tuple[int, frozenset[str]]], end: int) -> Any:
    monitor.feed(samples)
    monitor.end(end)
    return list(monitor.verdicts()), monitor.memory()


def rtamt_spec(kind: Any, text: str) -> Any:
    spec = kind()
    for name in VARIABLES:
        spec.declare_var(name, "float")
    spec.spec = text
    spec.parse()
    return spec


def rtamt_discrete(spec: Any, rows: list[list[tuple[str, float]]]) -> list[float]:
    return [spec.update(tick, row) for tick, row in enumerate(rows)]


def rtamt_dense(spec: Any, pieces: list[list[list[Any]]]) -> list[list[float]]:
    out: list[list[float]] = []
    for piece in pieces:
        out += spec.update(*piece)
    return out


def reelay_discrete(monitor: Any, rows: list[dict[str, bool]]) -> list[dict[str, Any]]:
    return [monitor.update(row) for row in rows]


def reelay_dense(monitor: Any, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for row in rows:
        out += monitor.update(row)
    return out


def hand_loop(trace: Samples) -> tuple[list[int], int]:
    """HardBraking -> eventually[<=10s] Stopped, written for this formula only: the
    hard-braking samples with no Stopped within 1000 ticks, and up to where that is
    decided. A sample expires before a Stopped at the same tick can clear it."""
    waiting: deque[int] = deque()
    violations: list[int] = []
    for t, state in trace:
        while waiting and t - waiting[0] > 1000:
            violations.append(waiting.popleft())
        if state == "Stopped":
            waiting.clear()
        elif state == "HardBraking":
            waiting.append(t)
    return violations, len(trace) - 1000


# ---- verdicts, read the same way for every tool ----


def false_ticks(segments: list[Segment], last: int) -> tuple[set[int], int]:
    """The samples (ticks 0..last) where a verdict is false, and the first tick
    that is not decided."""
    found: set[int] = set()
    decided = last + 1
    for a, b, a_closed, b_closed, value in merge(segments):
        first = math.ceil(a) if a_closed else math.floor(a) + 1
        final = min(math.floor(b) if b_closed else math.ceil(b) - 1, last)
        if value == "unknown" and first <= final:
            decided = min(decided, first)
        elif value == "false":
            found.update(range(first, final + 1))
    return {t for t in found if t < decided}, decided


def steps_of_segments(segments: list[Segment]) -> Steps:
    """The verdict as a step function, up to the first unknown stretch (the points
    alone, which a step function cannot hold, are left out)."""
    times: list[float] = []
    values: list[bool] = []
    for a, b, _, _, value in merge(segments):
        if a < b and value == "unknown":
            return times, values, float(a)
        if a < b:
            times.append(float(a))
            values.append(value == "true")
    return times, values, float(segments[-1][1]) if segments else 0.0


def compare_discrete(tools: dict[str, tuple[set[int], int]]) -> int:
    """The tools' false samples agree wherever all decide; the number of them."""
    upto = min(decided for _, decided in tools.values())
    first_name, (first, _) = next(iter(tools.items()))
    mine = {t for t in first if t < upto}
    for name, (theirs, _) in tools.items():
        theirs = {t for t in theirs if t < upto}
        if theirs != mine:
            tick = min(mine ^ theirs)
            raise Disagreement(
                f"{name} and {first_name} disagree at tick {tick}: "
                f"{name} says {'false' if tick in theirs else 'true'}"
            )
    return len(mine)


def compare_dense(tools: dict[str, Steps], tolerance: dict[str, float]) -> None:
    """The tools' verdicts agree on every open interval between their change points
    (away from each tool's own tolerance around its change points)."""
    upto = min(steps[2] for steps in tools.values())
    cuts = sorted({t for times, _, _ in tools.values() for t in times if t < upto} | {upto})
    names = list(tools)
    for low, high in itertools.pairwise(cuts):
        middle = (low + high) / 2
        seen = {}
        for name in names:
            if high - low <= 2 * tolerance.get(name, 0.0):
                continue
            times, values, _ = tools[name]
            index = bisect.bisect_right(times, middle) - 1
            seen[name] = values[index] if index >= 0 else None
        if len(set(seen.values())) > 1:
            raise Disagreement(f"at t = {middle} ticks the verdicts differ: {seen}")


# ---- the two sections ----


def per_sample(trace: Samples, repeat: int, reference_samples: int) -> dict[str, Any]:
    sets = {s: frozenset({s}) for s in STATES}
    ours_input = [(t, sets[s]) for t, s in trace]
    rtamt_rows = [[(v, 1.0 if s == state else -1.0) for v, s in VARIABLES.items()]
                  for _, state in trace]  # fmt: skip
    reelay_rows = [{s: s == state for s in VARIABLES.values()} for _, state in trace]
    last = trace[-1][0]
    rows: dict[str, Any] = {}
    for name in FORMULAS:
        formula = compiled(name)
        seconds, (segments, memory) = best(
            repeat, lambda f=formula: Monitor(f), lambda m: fed(m, ours_input, last + 1)
        )
        verdicts = {"rmvdsl": false_ticks(segments, last)}
        row: dict[str, Any] = {"rmvdsl": len(trace) / seconds, "memory": memory}
        if name in RTAMT_DISCRETE and _installed("rtamt"):
            text = RTAMT_DISCRETE[name]
            make = partial(rtamt_spec, rtamt.StlDiscreteTimeSpecification, text)
            out = timed(
                row, "rtamt", len(trace), repeat, make, partial_run(rtamt_discrete, rtamt_rows)
            )
            verdicts["rtamt"] = ({t for t, r in enumerate(out) if r < 0}, len(trace))
        if name in REELAY and _installed("reelay"):
            pattern = REELAY[name]
            make = partial(reelay.discrete_timed_monitor, pattern=pattern)
            out = timed(
                row, "reelay", len(trace), repeat, make, partial_run(reelay_discrete, reelay_rows)
            )
            verdicts["reelay"] = (_reelay_false(out, len(trace)), len(trace))
        if name == "eventually":
            seconds, (violations, decided) = best(repeat, lambda: None, lambda _: hand_loop(trace))
            row["hand loop"] = len(trace) / seconds
            verdicts["hand loop"] = (set(violations), decided)
        row["violations"] = compare_discrete(verdicts)
        row["reference"] = check_reference(formula, trace[:reference_samples])
        rows[name] = row
    return rows


def _reelay_false(out: list[dict[str, Any]], count: int) -> set[int]:
    found, value = set(), True
    for tick, change in enumerate(out):
        value = change.get("value", value)
        if not value:
            found.add(tick)
    return found


def per_change(trace: Samples, repeat: int) -> dict[str, Any]:
    points = change_points(trace)
    end = trace[-1][0] + 1
    sets = {s: frozenset({s}) for s in STATES}
    ours_input = [(t, sets[s]) for t, s in points]
    reelay_rows = [{"time": t, **{s: s == state for s in VARIABLES.values()}}
                   for t, state in [*points, (end, points[-1][1])]]  # fmt: skip
    following = [t for t, _ in points[1:]] + [end]
    rtamt_pieces = [
        [[v, [[t, value], [next_t - RAMP, value]]] for v, value in _levels(state)]
        for (t, state), next_t in zip(points, following, strict=True)
    ]
    rows: dict[str, Any] = {}
    for name in FORMULAS:
        formula = compiled(name)
        seconds, (segments, memory) = best(
            repeat, lambda f=formula: Monitor(f), lambda m: fed(m, ours_input, end)
        )
        row: dict[str, Any] = {"rmvdsl": len(points) / seconds, "memory": memory}
        row["false segments"] = sum(1 for s in merge(segments) if s[4] == "false")
        steps = {"rmvdsl": steps_of_segments(segments)}
        if name in REELAY and _installed("reelay"):
            pattern = REELAY[name]
            make = partial(reelay.dense_timed_monitor, pattern=pattern)
            out = timed(
                row, "reelay", len(points), repeat, make, partial_run(reelay_dense, reelay_rows)
            )
            steps["reelay"] = ([float(o["time"]) for o in out], [o["value"] for o in out], end)
        if name in RTAMT_DENSE and _installed("rtamt"):
            text = RTAMT_DENSE[name]
            make = partial(rtamt_spec, rtamt.StlDenseTimeSpecification, text)
            out = timed(
                row, "rtamt", len(points), repeat, make, partial_run(rtamt_dense, rtamt_pieces)
            )
            steps["rtamt"] = (
                [float(t) for t, _ in out],
                [r >= 0 for _, r in out],
                float(out[-1][0]) if out else 0.0,
            )
        compare_dense(steps, {"rtamt": RAMP})
        rows[name] = row
    return rows


def _levels(state: str) -> Iterable[tuple[str, float]]:
    return [(v, 1.0 if s == state else -1.0) for v, s in VARIABLES.items()]


def check_reference(formula: Any, prefix: Samples) -> dict[str, Any]:
    """The monitor equals the reference evaluator on a prefix: the same segments."""
    points = change_points(prefix)
    end = prefix[-1][0] + 1
    times = [Fraction(t) for t, _ in points]
    states = [frozenset({s}) for _, s in points]
    start = time.perf_counter()
    expected = Reference(Trace(times, states, Fraction(end))).segments(formula)
    seconds = time.perf_counter() - start
    got = merge(fed(Monitor(formula), list(zip(times, states, strict=True)), end)[0])
    if got != expected:
        raise Disagreement(f"the monitor and the reference evaluator differ on {len(prefix)} ticks")
    return {"samples": len(prefix), "changes": len(points), "per_s": len(points) / seconds}


def _installed(module: str) -> bool:
    if globals()[module] is None:
        print(f"({module} is not installed: pip install {module})")
        return False
    return True


# ---- report ----


def table(rows: dict[str, Any], tools: list[str], unit: str, count: str) -> list[str]:
    header = f"{'formula':<13}" + "".join(f"{tool + unit:>16}" for tool in tools)
    lines = [header + f"{count:>16}   rmvdsl's speed / theirs"]
    for name, row in rows.items():
        cells = [f"{row[tool]:>16,.0f}" if row.get(tool) else f"{'-':>16}" for tool in tools]
        ratios = [f"{tool} {row['rmvdsl'] / row[tool]:.2f}x" for tool in tools[1:] if row.get(tool)]
        lines.append(f"{name:<13}{''.join(cells)}{row[count]:>16,}   " + ", ".join(ratios or ["-"]))
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--samples", type=int, default=50_000, help="per-sample section")
    parser.add_argument("--dense-samples", type=int, default=1_000_000, help="per-change section")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--reference-samples", type=int, default=20_000)
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args()

    trace, dense = generate(args.samples), generate(args.dense_samples)
    changes, dense_points = len(change_points(trace)) - 1, len(change_points(dense))
    try:
        samples_rows = per_sample(trace, args.repeat, args.reference_samples)
        change_rows = per_change(dense, args.repeat)
    except Disagreement as exc:
        print(f"the tools disagree, so no speed is reported: {exc}", file=sys.stderr)
        return 1
    print(f"per sample: {len(trace):,} samples at 100 Hz ({changes:,} state changes), "
          f"verdicts equal at every sample; samples per second, best of {args.repeat}")  # fmt: skip
    for line in table(samples_rows, ["rmvdsl", "rtamt", "reelay", "hand loop"], "/s", "violations"):
        print(line)
    print(f"\nper change: the {dense_points:,} change points of {len(dense):,} samples, "
          "verdicts equal on every interval; change points per second")  # fmt: skip
    for line in table(change_rows, ["rmvdsl", "reelay", "rtamt"], "/s", "false segments"):
        print(line)
    print("\nreference evaluator, equal segments on a prefix: "
          + ", ".join(f"{name} {row['reference']['changes']} changes"
                      for name, row in samples_rows.items()))  # fmt: skip
    if args.json:
        payload = {
            "per_sample": {"samples": len(trace), "changes": changes, "rows": samples_rows},
            "per_change": {
                "samples": len(dense),
                "change_points": dense_points,
                "rows": change_rows,
            },
            "repeat": args.repeat,
        }
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(payload, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
