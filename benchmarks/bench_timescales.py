"""The timescales suite (D. Ulus, "Timescales: a benchmark generator for MTL
monitoring tools", RV 2019): `rmv eval` beside reelay's discrete and dense monitors,
each a process of its own reading the same file, verdicts compared before any
figure is printed.

The suite's ten past-time patterns (absence, universality, recurrence and response;
globally, after q, before r, between q and r) with its bounds (lower 3, upper 10 by
default), and traces made by its generator's rules, written here: one row per time
unit, each pattern's rows built so that the pattern holds at every row, then a
failing end. The traces are seeded data; the rules are the suite's.

rmvdsl's bounds are `[<T]`, `[<=T]` and `[=T]`; the suite's `[a:b]` and `[b:]`
windows are written with them (`once[3:10] p` is `once[=3] once[<=7] p`; `phi
since[3:10] psi` is `historically[<3] phi and once[=3] (phi since[<=7] psi)`; `phi
since[10:] psi` is `historically[<10] phi and once[=10] (phi since psi)`), and the
suite's unbounded `since` and `once` are rmvdsl's. The suite writes AbsentBQR's
`historically` around the antecedent only, a slip its universality twin does not
make; both tools here read it around the whole implication.

Each tool reads the trace as JSON Lines (`{"t": 12, "props": ["p", "q"]}`): `rmv
eval --all --format json`, and a Python process that reads each line with
json.loads and feeds reelay (25.0, from PyPI) a row per line: its discrete monitor
(rows) and its dense one (rows with their time). Figures are CPU seconds (user and
system) of each whole process and its peak resident memory, medians of --repeat
rounds (each round runs the three tools one after another, starting with the
next one each round), and each ratio the median of the rounds' ratios: paired
runs, as the machine is shared. The verdicts are
compared at every row (rmvdsl's value at the row's time against reelay's discrete
output) and on every open interval between change points (against reelay's dense
output): a disagreement ends the benchmark, exit status 1, before any figure.

    python benchmarks/bench_timescales.py                      # 10^4, 10^5, 10^6 rows
    python benchmarks/bench_timescales.py --repeat 5 --json benchmarks/results/timescales.json
"""

from __future__ import annotations

import argparse
import bisect
import itertools
import json
import os
import random
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from fractions import Fraction
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import peak
from as_installed import byte_compile

ROOT = Path(__file__).resolve().parent.parent
Row = tuple[int, frozenset[str]]

READ_AND_FEED = """
import json, sys
import reelay

mode, pattern, path, names = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4].split(",")
dense = mode == "dense"
monitor = (reelay.dense_timed_monitor if dense else reelay.discrete_timed_monitor)(pattern=pattern)
out, value = [], True
with open(path, encoding="utf-8") as handle:
    for line in handle:
        record = json.loads(line)
        props = set(record.get("props", ()))
        row = {name: name in props for name in names}
        if dense:
            row["time"] = record["t"]
            out += monitor.update(row)
        else:
            value = monitor.update(row).get("value", value)  # given when it changes
            if not value and "end" not in record:
                out.append(record["t"])
print(json.dumps(out))
"""


# ---- the patterns: the suite's text for reelay, rmvdsl's formulas ----


class Ours:
    """rmvdsl's formulas for the suite's operators, in one of three readings of
    `phi since psi` (the rest read alike):

    - "dense", rmvdsl's own (RMTLD3's): a row holds for its time unit, and phi must
      hold on all of (t', t] for a t' where psi holds, so phi must start before psi
      ends. This is the formula a user writes, and the one timed.
    - "rows", the suite's and reelay's discrete monitor's: a row at a time, phi from
      the row after psi's on; at every row that is `psi or (phi since (phi and
      once[=1] psi))` in dense time.
    - "strong", reelay's dense monitor's: phi also at t' itself, `phi since (phi
      and psi)`.

    The benchmark checks the second against reelay's discrete verdicts and the third
    against its dense ones, exactly: the readings are the only difference."""

    def __init__(self, reading: str) -> None:
        self.reading = reading

    def since(self, phi: str, psi: str, bound: int | None = None) -> str:
        """phi since[0:bound] psi (no bound: None)."""
        window = "" if bound is None else f"[<={bound}]"
        if self.reading == "strong":
            return f"({phi} since{window} ({phi} and {psi}))"
        if self.reading == "dense":
            return f"({phi} since{window} {psi})"
        if bound == 0:
            return psi
        window = "" if bound is None else f"[<={bound - 1}]"
        return f"({psi} or ({phi} since{window} ({phi} and once[=1] {psi})))"

    def since_from(self, phi: str, psi: str, low: int, high: int | None) -> str:
        """phi since[low:high] psi: phi on the last `low` and, `low` back, since."""
        recent = f"historically[<{low}] {phi}"
        if self.reading == "rows":  # the rows after the one `low` back
            recent = phi if low == 1 else f"historically[<={low - 1}] {phi}"
        rest = None if high is None else high - low
        return f"({recent} and once[={low}] {self.since(phi, psi, rest)})"


def patterns(a: int, b: int, reading: str = "dense") -> dict[str, tuple[str, str]]:
    """Each pattern with the lower bound a and the upper bound b: the suite's text
    (reelay reads it) and rmvdsl's formula in one reading (Ours)."""
    ours = Ours(reading)
    between = "({r} && !{q} && once {q})"
    ours_between = "(r and not q and once q)"
    respond = (
        f"((s -> once[={a}] once[<={b - a}] p) and not {ours.since_from('(not s)', 'p', b, None)})"
    )
    return {
        "AbsentAQ": (
            f"historically((once[:{b}]({{q}})) -> ((not {{p}}) since {{q}}))",
            f"historically ((once[<={b}] q) -> {ours.since('(not p)', 'q')})",
        ),
        "AbsentBR": (
            f"historically({{r}} -> (historically[:{b}](not {{p}})))",
            f"historically (r -> historically[<={b}] not p)",
        ),
        "AbsentBQR": (
            f"historically({between} -> ((not {{p}}) since[{a}:{b}] {{q}}))",
            f"historically ({ours_between} -> {ours.since_from('(not p)', 'q', a, b)})",
        ),
        "AlwaysAQ": (
            f"historically((once[:{b}]({{q}})) -> ({{p}} since {{q}}))",
            f"historically ((once[<={b}] q) -> {ours.since('p', 'q')})",
        ),
        "AlwaysBR": (
            f"historically({{r}} -> (historically[:{b}]({{p}})))",
            f"historically (r -> historically[<={b}] p)",
        ),
        "AlwaysBQR": (
            f"historically({between} -> ({{p}} since[{a}:{b}] {{q}}))",
            f"historically ({ours_between} -> {ours.since_from('p', 'q', a, b)})",
        ),
        "RecurGLB": (f"historically(once[:{b}]({{p}}))", f"historically once[<={b}] p"),
        "RecurBQR": (
            f"historically({between} -> ((once[:{b}]({{p}} or {{q}})) since {{q}}))",
            f"historically ({ours_between} -> {ours.since(f'(once[<={b}] (p or q))', 'q')})",
        ),
        "RespondGLB": (
            f"historically(({{s}} -> once[{a}:{b}] {{p}}) and not(not({{s}}) since[{b}:] {{p}}))",
            f"historically {respond}",
        ),
        "RespondBQR": (
            f"historically({between} -> ((({{s}} -> once[{a}:{b}] {{p}}) and "
            f"not(not({{s}}) since[{b}:] {{p}})) since {{q}}))",
            f"historically ({ours_between} -> {ours.since(respond, 'q')})",
        ),
    }


# ---- the traces: the suite generator's rules, one row per time unit ----


class Rows:
    """Rows in time order, one per time unit from 0."""

    def __init__(self) -> None:
        self.rows: list[Row] = []

    def add(self, *names: str, times: int = 1) -> None:
        state = frozenset(names)
        for _ in range(times):
            self.rows.append((len(self.rows), state))

    def maybe(self, draw: random.Random, name: str, *others: str) -> None:
        self.add(*others, *((name,) if draw.random() < 0.5 else ()))


def absent_after(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        out.add("q")
        out.add(times=b)
        for _ in range(b):
            out.maybe(draw, "p")
    out.add("q")
    out.add(times=b - 1)
    out.add("p")


def absent_before(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        for _ in range(b):
            out.maybe(draw, "p")
        out.add(times=b)
        out.add("r")
    out.add("p")
    out.add(times=b - 1)
    out.add("r")


def absent_between(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        out.add("q")
        out.add(times=draw.randint(a, b - 1))
        out.add("r")
        out.maybe(draw, "p")
    out.add("q")
    out.add(times=b - 1)
    out.add("p")
    out.add("r")


def always_after(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        out.add("q", "p")
        out.add("p", times=b)
        for _ in range(b):
            out.maybe(draw, "p")
    out.add("q")
    out.add("p", times=b - 1)
    out.add()


def always_before(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        for _ in range(b):
            out.maybe(draw, "p")
        out.add("p", times=b)
        out.add("p", "r")
    out.add()
    out.add("p", times=b - 1)
    out.add("p", "r")


def always_between(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        out.add("q", "p")
        out.add("p", times=draw.randint(a, b - 1))
        out.add("p", "r")
        out.add()
    out.add("q", "p")
    out.add("p", times=b + 1)
    out.add("p", "r")


def recur_globally(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    out.add("p")
    while len(out.rows) < duration:
        out.add(times=draw.randint(1, b) - 1)
        out.add("p")
    out.add(times=b + 1)


def recur_between(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        out.add("q")
        gap = 1
        for _ in range(draw.randint(1, 7)):
            gap = draw.randint(1, b)
            out.add(times=gap - 1)
            out.add("p")
        out.add(times=gap - 1)
        out.add("r")
        out.add(times=gap - 1)
    out.add("q")
    out.add(times=b + 1)
    out.add("r")


def respond_globally(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        out.add("p")
        out.add(times=draw.randint(a + 1, b) - 1)
        out.add("s")
    out.add("p")
    out.add(times=b)


def respond_between(out: Rows, draw: random.Random, a: int, b: int, duration: int) -> None:
    while len(out.rows) < duration:
        out.add("q")
        out.add()
        for _ in range(draw.randint(1, 7)):
            out.add("p")
            out.add(times=draw.randint(a + 1, b) - 1)
            out.add("s")
            out.add()
        out.add("r")
    out.add("q")
    out.add("p")
    out.add(times=b + 1)
    out.add("r")


GENERATORS: dict[str, tuple[Callable[..., None], str]] = {
    "AbsentAQ": (absent_after, "pq"), "AbsentBR": (absent_before, "pr"),
    "AbsentBQR": (absent_between, "pqr"), "AlwaysAQ": (always_after, "pq"),
    "AlwaysBR": (always_before, "pr"), "AlwaysBQR": (always_between, "pqr"),
    "RecurGLB": (recur_globally, "p"), "RecurBQR": (recur_between, "pqr"),
    "RespondGLB": (respond_globally, "ps"), "RespondBQR": (respond_between, "pqrs"),
}  # fmt: skip


def trace(name: str, rows: int, a: int, b: int, seed: int = 2019) -> list[Row]:
    """About `rows` rows of the pattern's trace (the suite's `duration`), then its
    failing end."""
    out = Rows()
    GENERATORS[name][0](out, random.Random(f"{seed} {name}"), a, b, rows)
    return out.rows


def write(path: Path, rows: list[Row]) -> None:
    with path.open("w", encoding="utf-8") as handle:
        for t, state in rows:
            handle.write(json.dumps({"t": t, "props": sorted(state)}) + "\n")
        handle.write(json.dumps({"t": len(rows), "end": True}) + "\n")


# ---- running and comparing ----


def measure(command: list[str]) -> tuple[float, float, str]:
    """CPU seconds (user and system) and peak resident MB of one process (its own:
    benchmarks/peak.py), and its output."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with tempfile.TemporaryFile() as out:
        usage = peak.run(command, stdout=out, env=env, cwd=ROOT)
        if usage.returncode:
            raise SystemExit(f"{command[:5]} failed with status {usage.returncode}: {usage.stderr}")
        out.seek(0)
        text = out.read().decode()
    return usage.cpu, usage.peak_bytes / 2**20, text


def false_rows(segments: list[dict[str, Any]], count: int) -> list[int]:
    """The rows (times 0 .. count - 1) where rmvdsl's verdict is false."""
    out: list[int] = []
    for segment in segments:
        if segment["verdict"] != "false":
            continue
        low, high = Fraction(segment["from"]), Fraction(segment["to"])
        first = int(low) + (0 if low == int(low) and segment["from_closed"] else 1)
        last = int(high) - (0 if high != int(high) or segment["to_closed"] else 1)
        out.extend(range(first, min(last, count - 1) + 1))
    return out


def steps(segments: list[dict[str, Any]]) -> tuple[list[float], list[bool]]:
    """rmvdsl's verdict as a step function of open intervals (points left out)."""
    times, values = [], []
    for segment in segments:
        low, high = Fraction(segment["from"]), Fraction(segment["to"])
        if low < high:
            times.append(float(low))
            values.append(segment["verdict"] == "true")
    return times, values


def compare_dense(name: str, ours: tuple[list[float], list[bool]], dense: list[Any],
                  end: int) -> None:  # fmt: skip
    """Equal on every open interval between the two step functions' changes."""
    times, values = ours
    theirs_t = [float(o["time"]) for o in dense]
    theirs_v = [bool(o["value"]) for o in dense]
    cuts = sorted({*times, *theirs_t, float(end)})
    for low, high in itertools.pairwise(cuts):
        middle = (low + high) / 2
        at = bisect.bisect_right(times, middle) - 1
        there = bisect.bisect_right(theirs_t, middle) - 1
        if at >= 0 and there >= 0 and values[at] != theirs_v[there]:
            raise Disagreement(f"{name}: rmv eval and reelay (dense) differ at t = {middle}")


class Disagreement(Exception):
    pass


def eval_command(formula: str, path: Path) -> list[str]:
    return [sys.executable, "-m", "rmvdsl.cli", "eval", "--formula", formula,
            "--trace", str(path), "--all", "--format", "json"]  # fmt: skip


def run(sizes: list[int], a: int, b: int, repeat: int, only: list[str]) -> Iterator[dict[str, Any]]:
    readings = {r: patterns(a, b, r) for r in ("dense", "rows", "strong")}
    with tempfile.TemporaryDirectory() as folder:
        for count in sizes:
            for name in readings["dense"]:
                if only and name not in only:
                    continue
                path = Path(folder) / f"{name}.jsonl"
                # written by another process: a child forked from a parent holding the
                # rows would count them in its own peak memory
                written = subprocess.run(
                    [sys.executable, __file__, "--write", str(path), name, str(count), str(a),
                     str(b)], check=True, capture_output=True, text=True)  # fmt: skip
                texts = {reading: found[name] for reading, found in readings.items()}
                yield one(name, texts, path, int(written.stdout), repeat)


def one(name: str, texts: dict[str, tuple[str, str]], path: Path, length: int,
        repeat: int) -> dict[str, Any]:  # fmt: skip
    """One pattern over one trace: the three tools timed in `repeat` rounds, each
    round running each tool once in turn (the first tool moving on by one each
    round), the verdicts compared. Each tool's figures are its medians; the ratios
    are the medians of each round's ratio (paired runs: the machine is shared)."""
    pattern, formula = texts["dense"]
    names = ",".join(GENERATORS[name][1])
    reelay = [sys.executable, "-c", READ_AND_FEED]
    timed = {
        "rmv eval": eval_command(formula, path),
        "reelay discrete": [*reelay, "discrete", pattern, str(path), names],
        "reelay dense": [*reelay, "dense", pattern, str(path), names],
    }
    tools = list(timed)
    rounds: list[dict[str, tuple[float, float, str]]] = []
    for turn in range(repeat):
        order = tools[turn % len(tools) :] + tools[: turn % len(tools)]
        rounds.append({tool: measure(timed[tool]) for tool in order})
    row: dict[str, Any] = {"pattern": name, "rows": length}
    outputs: dict[str, Any] = {}
    for tool in tools:
        row[tool] = {"cpu_s": median([r[tool][0] for r in rounds]),
                     "peak_mb": median([r[tool][1] for r in rounds])}  # fmt: skip
        outputs[tool] = json.loads(rounds[0][tool][2])
    # reelay's two readings of `since`, written in rmvdsl, give reelay's verdicts
    by_rows = json.loads(measure(eval_command(texts["rows"][1], path))[2])
    strong = json.loads(measure(eval_command(texts["strong"][1], path))[2])
    false = false_rows(by_rows["segments"], length)
    if false != outputs["reelay discrete"]:
        first = min(set(false) ^ set(outputs["reelay discrete"]))
        raise Disagreement(f"{name}: rmv eval and reelay (discrete) differ at row {first}")
    compare_dense(name, steps(strong["segments"]), outputs["reelay dense"], length)
    row["false rows"] = len(false)
    row["rows false in dense time"] = len(false_rows(outputs["rmv eval"]["segments"], length))
    for baseline in ("reelay discrete", "reelay dense"):
        row[f"rmv eval / {baseline}"] = median([r["rmv eval"][0] / r[baseline][0] for r in rounds])
    return row


def median(values: list[float]) -> float:
    ordered = sorted(values)
    middle = len(ordered) // 2
    return ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--rows", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    parser.add_argument("--lower", type=int, default=3)
    parser.add_argument("--upper", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3,
                        help="rounds: the figures are medians, the ratios paired")  # fmt: skip
    parser.add_argument("--pattern", action="append", default=[], help="only these")
    parser.add_argument("--json", metavar="FILE")
    parser.add_argument("--write", nargs=5, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.write:
        path, name, count, a, b = args.write
        rows = trace(name, int(count), int(a), int(b))
        write(Path(path), rows)
        print(len(rows))
        return 0
    byte_compile()
    results = []
    print(f"{'pattern':<11} {'rows':>9} {'rmv eval':>9} {'discrete':>9} {'dense':>9}"
          f" {'ratio':>6} {'MB (ours/theirs)':>17} {'false rows (dense)':>18}")  # fmt: skip
    try:
        for result in run(args.rows, args.lower, args.upper, args.repeat, args.pattern):
            results.append(result)
            ours, theirs = result["rmv eval"], result["reelay discrete"]
            print(f"{result['pattern']:<11} {result['rows']:>9,} {ours['cpu_s']:>8.2f}s"
                  f" {theirs['cpu_s']:>8.2f}s {result['reelay dense']['cpu_s']:>8.2f}s"
                  f" {result['rmv eval / reelay discrete']:>5.2f}x"
                  f" {ours['peak_mb']:>8.0f}/{theirs['peak_mb']:<8.0f}"
                  f" {result['false rows']:>10} ({result['rows false in dense time']})",
                  flush=True)  # fmt: skip
    except Disagreement as exc:
        print(f"the tools disagree, so no figures are kept: {exc}", file=sys.stderr)
        return 1
    if args.json:
        payload = {"lower": args.lower, "upper": args.upper, "repeat": args.repeat,
                   "results": results}  # fmt: skip
        Path(args.json).write_text(json.dumps(payload, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
