"""Throughput and memory of the online RMTLD3 monitor (issue 4).

A braking controller sampled at 100 Hz: four states (Cruising, HardBraking,
AntiLockBrake, Stopped), each held a random 0.05-3 s (seeded). Time is counted in
10 ms ticks (integers: exact). Four formulas, side by side in one run with:

- the reference evaluator (rmvdsl.logic.reference), on a prefix;
- rtamt's discrete-time online monitor (pip install rtamt), states as +1/-1
  variables, future formulas pastified; it has no durations (formula 3.1);
- reelay's discrete timed monitor (pip install reelay), past time only;
- a hand-written single-formula loop for `HardBraking -> eventually[<=10s] Stopped`.

Figures are samples per second, best of --repeat, and ratios in the same run.

    python benchmarks/bench_monitor.py                  # 1,000,000 samples
    python benchmarks/bench_monitor.py --samples 200000 --json out.json
"""

from __future__ import annotations

import argparse
import gc
import json
import random
import sys
import time
from collections import deque
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import itertools

from rmvdsl.grammar.parser import parse_formula
from rmvdsl.logic.compile import compile_formula
from rmvdsl.logic.reference import Reference, Trace
from rmvdsl.runtime.rmtld3 import Monitor

STATES = ("Cruising", "HardBraking", "AntiLockBrake", "Stopped")
TICK = Fraction(1, 100)  # seconds per tick

FORMULAS = {
    "formula 3.1": "(HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped) "
    "and duration[10s](HardBraking) < 4s",
    "until part": "HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped",
    "eventually": "HardBraking -> eventually[<=10s] Stopped",
    "past mirror": "Stopped -> once[<=10s] HardBraking",
}
RTAMT = {
    "until part": "(hb >= 0) implies (((ab >= 0) or (hb >= 0)) until[0:999] (st >= 0))",
    "eventually": "(hb >= 0) implies (eventually[0:1000] (st >= 0))",
    "past mirror": "(st >= 0) implies (once[0:1000] (hb >= 0))",
}
REELAY_PAST = "{Stopped} -> once[0:1000] {HardBraking}"


def generate(samples: int, seed: int = 2019) -> list[tuple[int, str]]:
    rng = random.Random(seed)
    trace: list[tuple[int, str]] = []
    state = "Cruising"
    tick = 0
    while tick < samples:
        hold = rng.randint(5, 300)  # 0.05 s to 3 s
        for _ in range(min(hold, samples - tick)):
            trace.append((tick, state))
            tick += 1
        state = rng.choice([s for s in STATES if s != state])
    return trace


def compiled(name: str) -> Any:
    node, diagnostics = parse_formula(FORMULAS[name], "rmv")
    assert node is not None, diagnostics
    return compile_formula(node, unit=TICK)


def best(repeat: int, action: Callable[[], Any]) -> tuple[float, Any]:
    times, result = [], None
    for _ in range(repeat):
        gc.collect()
        start = time.perf_counter()
        result = action()
        times.append(time.perf_counter() - start)
    return min(times), result


def run_monitor(formula: Any, trace: list[tuple[int, str]]) -> dict[str, Any]:
    sets = {s: frozenset({s}) for s in STATES}
    samples = [(t, sets[s]) for t, s in trace]
    monitor = Monitor(formula)
    memory = []
    quarter = len(samples) // 4
    for part in range(4):
        monitor.feed(samples[part * quarter : (part + 1) * quarter])
        memory.append(monitor.memory())
        for _ in monitor.verdicts():
            pass
    monitor.end(trace[-1][0] + 1)
    return {"memory": memory, "horizon_ticks": int(monitor.horizon)}


def run_reference(formula: Any, trace: list[tuple[int, str]]) -> None:
    times, states = [], []
    for t, s in trace:
        if not states or states[-1] != frozenset({s}):
            times.append(Fraction(t))
            states.append(frozenset({s}))
    Reference(Trace(times, states, Fraction(trace[-1][0] + 1))).segments(formula)


def hand_loop(trace: list[tuple[int, str]]) -> int:
    """HardBraking -> eventually[<=10s] Stopped, written for this formula only:
    count the hard-braking samples not followed by Stopped within 1000 ticks."""
    waiting: deque[int] = deque()
    violations = 0
    for t, state in trace:
        if state == "Stopped":
            waiting.clear()
        elif state == "HardBraking":
            waiting.append(t)
        while waiting and t - waiting[0] > 1000:
            waiting.popleft()
            violations += 1
    return violations


def run_rtamt(spec_text: str, trace: list[tuple[int, str]]) -> None:
    import rtamt

    spec = rtamt.StlDiscreteTimeSpecification()
    for name in ("hb", "ab", "st"):
        spec.declare_var(name, "float")
    spec.spec = spec_text
    spec.parse()
    if "eventually" in spec_text or "until" in spec_text:
        spec.pastify()
    for t, state in trace:
        spec.update(
            t,
            [
                ("hb", 1.0 if state == "HardBraking" else -1.0),
                ("ab", 1.0 if state == "AntiLockBrake" else -1.0),
                ("st", 1.0 if state == "Stopped" else -1.0),
            ],
        )


def run_reelay(trace: list[tuple[int, str]]) -> None:
    from reelay import discrete_timed_monitor

    monitor = discrete_timed_monitor(pattern=REELAY_PAST)
    for _, state in trace:
        monitor.update({"Stopped": state == "Stopped", "HardBraking": state == "HardBraking"})


def rate(samples: int, seconds: float) -> float:
    return samples / seconds if seconds > 0 else float("inf")


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--reference-samples", type=int, default=3000)
    parser.add_argument("--rtamt-samples", type=int, default=3000)
    parser.add_argument("--reelay-samples", type=int, default=200_000)
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args()

    trace = generate(args.samples)
    changes = sum(1 for a, b in itertools.pairwise(trace) if a[1] != b[1])
    print(f"{len(trace):,} samples at 100 Hz, {changes:,} state changes")
    results: dict[str, dict[str, Any]] = {}
    hand_seconds, _ = best(args.repeat, lambda: hand_loop(trace))
    hand_rate = rate(len(trace), hand_seconds)
    for name in FORMULAS:
        formula = compiled(name)
        seconds, info = best(args.repeat, lambda formula=formula: run_monitor(formula, trace))
        row: dict[str, Any] = {"rmvdsl": rate(len(trace), seconds), **info}
        prefix = trace[: args.reference_samples]
        ref_seconds, _ = best(
            1, lambda formula=formula, prefix=prefix: run_reference(formula, prefix)
        )
        row["reference"] = rate(len(prefix), ref_seconds)
        if name in RTAMT:
            try:
                part = trace[: args.rtamt_samples]
                rt_seconds, _ = best(1, lambda part=part, name=name: run_rtamt(RTAMT[name], part))
                row["rtamt"] = rate(len(part), rt_seconds)
            except ImportError:
                row["rtamt"] = None
        if name == "past mirror":
            try:
                part = trace[: args.reelay_samples]
                re_seconds, _ = best(args.repeat, lambda part=part: run_reelay(part))
                row["reelay"] = rate(len(part), re_seconds)
            except ImportError:
                row["reelay"] = None
        if name == "eventually":
            row["hand loop"] = hand_rate
        results[name] = row
    header = (
        f"{'formula':<13} {'rmvdsl/s':>12} {'reference/s':>12} {'rtamt/s':>10} {'reelay/s':>12} "
        f"{'hand/s':>12} {'vs rtamt':>9} {'vs reelay':>9} {'hand/us':>8}"
    )
    print(header + "  memory (breakpoints at 25/50/75/100%)")
    for name, row in results.items():
        ours = row["rmvdsl"]

        def cell(key: str, width: int, row: dict[str, Any] = row) -> str:
            value = row.get(key)
            return f"{value:>{width},.0f}" if value else f"{'-':>{width}}"

        versus_rtamt = f"{ours / row['rtamt']:>8.0f}x" if row.get("rtamt") else f"{'-':>9}"
        versus_reelay = f"{ours / row['reelay']:>8.2f}x" if row.get("reelay") else f"{'-':>9}"
        hand = f"{row['hand loop'] / ours:>7.2f}x" if row.get("hand loop") else f"{'-':>8}"
        cells = [cell("rmvdsl", 12), cell("reference", 12), cell("rtamt", 10), cell("reelay", 12)]
        cells += [cell("hand loop", 12), versus_rtamt, versus_reelay, hand]
        print(f"{name:<13} {' '.join(cells)}  {row['memory']}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
