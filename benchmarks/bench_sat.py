"""Satisfiability in dense time (issue 5): the upstream scaling families and sets
of interacting requirements, with a discrete-time baseline in the same run.

1. rmtld3synth's published families, b = 5, 20, 35, 45, 100, 1000:
   `\\always_{<b}(a \\lor b) \\until_{<b} r` and
   `a \\land \\always_{<b} a \\rightarrow \\eventually_{=2} a`.
   Each is asked "satisfiable?" and "valid?" with an empty cache. Upstream needs
   70 s (b = 20), 2,400 s (b = 35) and 1,842 s (second family, b = 45) on an i5.
   The baseline is the upstream approach rebuilt here: one z3 boolean per
   proposition per time unit, operators unrolled over their windows (its cost
   grows with b; it is stopped after --baseline-limit seconds).
2. Sets of 10, 20, 30 and 40 interacting requirements (bounds up to 1,000 ms),
   shaped like the published requirement sets (a pacemaker's timing rules: a
   pace starts the chain, every event answers within a bound, refractory periods
   forbid events, durations are capped): "can they all hold together?", and the
   whole `rmv check` of a spec that declares them (every property satisfiable,
   valid, vacuous; consistency; redundancy).

    python benchmarks/bench_sat.py
    python benchmarks/bench_sat.py --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import itertools

import z3

from rmvdsl.check import check
from rmvdsl.grammar.formula_parser import parse_formula
from rmvdsl.logic.answers import UNKNOWN
from rmvdsl.logic.compile import compile_formula
from rmvdsl.logic.sat import Cache, satisfiable, valid
from rmvdsl.util.cache import use_cache

FAMILIES = {
    "until family": r"\always_{<B}(a \lor b) \until_{<B} r",
    "eventually family": r"a \land \always_{<B} a \rightarrow \eventually_{=2} a",
}
# Harder neighbours: one refuted (needs the proof, not a witness), one that forces
# about 2b changes (beyond the witness search's 8 segments once b > 3: unknown).
HARDER = {
    "until, no r": r"\always_{<B}(a \lor b) \until_{<B} r \land \always_{<B} \neg r",
    "toggling": r"\always_{<B} (\eventually_{<=1} a \land \eventually_{<=1} \neg a)",
}
BOUNDS = (5, 20, 35, 45, 100, 1000)
EVENTS = ["APace", "ASense", "VPace", "VSense", "AVDelay", "Refractory", "Blanking", "Alarm"]


def latex(text: str) -> Any:
    node, diagnostics = parse_formula(text, "latex", "<bench>", "formula")
    assert node is not None, diagnostics
    return compile_formula(node)


def timed(action: Any) -> tuple[float, Any]:
    started = time.perf_counter()
    result = action()
    return time.perf_counter() - started, result


# ---- the discrete-time baseline: unit segments, unrolled windows ----


class Unrolled:
    """Upstream's encoding in spirit: proposition p at time unit i is a z3 boolean;
    `until` at i is a disjunction over its window of conjunctions over prefixes."""

    def __init__(self, deadline: float) -> None:
        self.cache: dict[tuple[int, int], Any] = {}
        self.atoms: dict[tuple[str, int], Any] = {}
        self.deadline = deadline

    def value(self, f: Any, i: int) -> Any:
        key = (id(f), i)
        if key not in self.cache:
            if time.perf_counter() > self.deadline:
                raise TimeoutError
            self.cache[key] = self._value(f, i)
        return self.cache[key]

    def _value(self, f: Any, i: int) -> Any:
        kind = f[0]
        if kind == "prop":
            return self.atoms.setdefault((f[1], i), z3.Bool(f"{f[1]}@{i}"))
        if kind == "const":
            return z3.BoolVal(f[1])
        if kind == "not":
            return z3.Not(self.value(f[1], i))
        if kind in ("and", "or"):
            parts = (self.value(f[1], i), self.value(f[2], i))
            return z3.And(*parts) if kind == "and" else z3.Or(*parts)
        _, op, bound, phi, psi = f
        bound = int(bound)
        window = {"<": range(i, i + bound), "<=": range(i, i + bound + 1), "=": [i + bound]}[op]
        options = []
        for j in window:
            prefix = [self.value(phi, k) for k in range(i, j)]
            options.append(z3.And(self.value(psi, j), *prefix))
        return z3.Or(*options) if options else z3.BoolVal(False)


def unrolled(formula: Any, negate: bool, limit: float) -> tuple[float, bool] | None:
    """Seconds to decide the formula (or its negation) by unrolling, and whether it
    is satisfiable; None if over the limit."""
    started = time.perf_counter()
    encoding = Unrolled(started + limit)
    try:
        goal = encoding.value(formula, 0)
    except TimeoutError:
        return None
    solver = z3.Solver()
    solver.set("timeout", max(1, int((limit - (time.perf_counter() - started)) * 1000)))
    solver.add(z3.Not(goal) if negate else goal)
    answer = solver.check()
    if answer == z3.unknown:
        return None
    return time.perf_counter() - started, answer == z3.sat


def agrees(ours: str, theirs: bool | None) -> bool:
    """Whether two decided answers agree (an undecided one agrees with anything:
    it is reported, not compared)."""
    return ours == "unknown" or theirs is None or (ours == "yes") == theirs


# ---- requirement sets ----


def requirements(count: int, seed: int = 1) -> list[str]:
    """Pacemaker-shaped timing rules over EVENTS, in the .rmv syntax, in ms: a pace
    starts a chain of events, each answering the previous within a bound; every
    event is preceded by a pace; refractory periods exclude sensing; the alarm
    excludes the chain; durations are capped."""
    rng = random.Random(seed)
    chain = ["VPace", "Refractory", "ASense", "AVDelay", "VSense"]
    rules = ["VPace"]
    for before, after in itertools.pairwise(chain):
        bound = rng.randrange(100, 400, 50)
        rules.append(f"always[<=1000ms] ({before} -> eventually[<={bound}ms] {after})")
    candidates = []
    for event in EVENTS[:-1]:
        candidates.append(f"always[<=1000ms] ({event} -> once[<=1000ms] VPace)")
        candidates.append(f"always[<=1000ms] not ({event} and Alarm)")
        candidates.append(f"duration[1000ms]({event}) <= {rng.randrange(500, 1000, 50)}ms")
        candidates.append(
            f"always[<=1000ms] ({event} -> always[<={rng.randrange(50, 200, 50)}ms] not Alarm)"
        )
    for a, b in itertools.pairwise(chain):
        candidates.append(f"always[<=1000ms] ({a} -> {a} until[<=500ms] {b})")
    candidates.append("always[<=1000ms] not (Refractory and VSense)")
    candidates.append("always[<=1000ms] (Blanking -> not ASense)")
    candidates.append("always[<=1000ms] (APace -> eventually[<=300ms] VPace)")
    rng.shuffle(candidates)
    rules.extend(candidates)
    assert len(rules) >= count, len(rules)
    return rules[:count]


def spec_text(rules: list[str]) -> str:
    lines = ['topic pacer: std_msgs/Float64MultiArray = "/pacer"']
    for index, name in enumerate(EVENTS):
        lines.append(f"var Level{index} = pacer.data[{index}]")
        lines.append(f"event {name} when Level{index} > 0.5")
    for index, rule in enumerate(rules):
        lines.append(f"property R{index + 1}: {rule}")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", metavar="FILE")
    parser.add_argument("--baseline-limit", type=float, default=10.0, metavar="SECONDS")
    args = parser.parse_args()
    # Never the user's cache: answers found here are neither read nor left there.
    os.environ["RMV_CACHE_DIR"] = tempfile.mkdtemp(prefix="rmv-bench-cache-")
    use_cache(None)
    out: dict[str, Any] = {"families": [], "sets": []}
    print("family               b      sat  valid   ours (s)  unrolled (s)  unrolled/ours")
    disagreements = []
    for name, template in {**FAMILIES, **HARDER}.items():
        over = False
        for bound in BOUNDS:
            formula = latex(template.replace("B", str(bound)))
            ours_sat, sat = timed(lambda f=formula: satisfiable([f], cache=Cache()))
            ours_valid, validity = timed(lambda f=formula: valid(f, cache=Cache()))
            ours = ours_sat + ours_valid
            base, base_sat, base_valid = None, None, None
            if not over:
                first = unrolled(formula, False, args.baseline_limit)
                second = unrolled(formula, True, args.baseline_limit)
                if first is not None and second is not None:
                    base, base_sat, base_valid = first[0] + second[0], first[1], not second[1]
                over = base is None
            # The baseline's verdicts are checked before any speed is compared: the
            # families' bounds are whole time units, where discrete and dense time
            # agree on them.
            if not (agrees(sat.value, base_sat) and agrees(validity.value, base_valid)):
                disagreements.append((name, bound, sat.value, validity.value, base_sat, base_valid))
            decided = UNKNOWN not in (sat.value, validity.value)
            if base and decided:
                ratio = f"{base / ours:13.1f}x"
            else:
                ratio = "  (over limit)" if not base else "  (ours unknown)"
            shown = f"{base:12.3f}" if base else f"{'>' + str(args.baseline_limit):>12}"
            print(
                f"{name:18} {bound:5}  {sat.value:>5}  {validity.value:>5}  {ours:9.3f}"
                f"  {shown}  {ratio}"
            )
            out["families"].append(
                {
                    "family": name,
                    "formula": template,
                    "b": bound,
                    "sat": sat.value,
                    "valid": validity.value,
                    "seconds": ours,
                    "unrolled_seconds": base,
                    "unrolled_sat": base_sat,
                    "unrolled_valid": base_valid,
                }
            )
    if disagreements:
        raise SystemExit(f"the answers differ from the baseline's: {disagreements}")
    print("\nrequirements  together  consistency (s)  rmv check (s)  diagnostics")
    for count in (10, 20, 30, 40):
        rules = requirements(count)
        compiled = []
        for rule in rules:
            node, _ = parse_formula(rule, "rmv", "<bench>", "formula")
            assert node is not None, rule
            compiled.append(compile_formula(node))
        seconds, together = timed(lambda c=compiled: satisfiable(c, cache=Cache()))
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "pacemaker.rmv"
            path.write_text(spec_text(rules), encoding="utf-8")
            use_cache(Cache())  # empty, in memory only: all the solver work is timed
            checking, result = timed(lambda p=path: check(str(p)))
        codes = sorted({d.code for d in result.diagnostics})
        print(f"{count:12}  {together.value:>8}  {seconds:15.3f}  {checking:13.3f}  {codes}")
        out["sets"].append(
            {
                "requirements": count,
                "together": together.value,
                "consistency_seconds": seconds,
                "check_seconds": checking,
                "codes": codes,
            }
        )
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2), encoding="utf-8")


if __name__ == "__main__":
    main()
