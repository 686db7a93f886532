"""`rmv eval` end to end: samples per second and peak memory against the trace's length.

The braking controller of bench_monitor.py at 100 Hz, written as JSON Lines (times in
seconds with two decimals, as a logger writes them) at 100,000 and 1,000,000 samples,
and formula 3.1. Each command runs as its own process (its start-up included); peak
memory is the process's own maximum resident set. In the same run, beside it:

- `json.loads` per line: a plain Python reader of the same file that does nothing
  with what it reads (the speed a JSON Lines tool starts from);
- the whole trace in memory: the same monitor fed after reading the whole file into
  lists (how `rmv eval` worked before it streamed), same output.

Goals (issue 16): at least 500,000 samples a second end to end, memory flat in the
trace's length. Best of --repeat.

    python benchmarks/bench_eval.py [--json benchmarks/results/eval.json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_monitor import generate

ROOT = Path(__file__).resolve().parent.parent
FORMULA = (
    "(HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped) "
    "and duration[10s](HardBraking) < 4s"
)
BARE_JSON = """
import json, sys
count = 0
with open(sys.argv[1], encoding="utf-8") as handle:
    for line in handle:
        json.loads(line)
        count += 1
print(count)
"""
WHOLE_TRACE = """
import sys
from rmvdsl.logic import evaluate as ev
from rmvdsl.logic.traces import read_trace

path, formula = sys.argv[1], sys.argv[2]
with open(path, encoding="utf-8") as handle:
    trace = read_trace(path, handle.read())
node, _ = ev.parse(formula, "auto", False)
compiled, _ = ev.compile_or_diagnose(node, trace.unit_seconds, trace.unit, [], formula)
result = ev.run(compiled, trace)
sys.stdout.write(ev.as_json({
    "segments": [ev.segment_json(s) for s in result.segments],
    "beyond": [ev.segment_json(s) for s in result.beyond],
    "horizon": result.horizon,
    "memory": {"held": result.memory, "bound": result.bound()},
}))
"""


def write_trace(path: Path, samples: int) -> None:
    with path.open("w", encoding="utf-8") as handle:
        for tick, state in generate(samples):
            handle.write(f'{{"t": {tick // 100}.{tick % 100:02d}, "state": "{state}"}}\n')
        handle.write(f'{{"t": {samples // 100}.{samples % 100:02d}, "end": true}}\n')


def measure(command: list[str], output: Path) -> tuple[float, float]:
    """Wall seconds and peak resident MB of one process."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with output.open("w") as out:
        start = time.perf_counter()
        process = subprocess.Popen(command, stdout=out, env=env, cwd=ROOT)
        _, status, usage = os.wait4(process.pid, 0)
        seconds = time.perf_counter() - start
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode:
        raise SystemExit(f"{command[:4]} failed with status {process.returncode}")
    return seconds, usage.ru_maxrss / 1024


def commands(trace: Path) -> dict[str, list[str]]:
    python = sys.executable
    options = ["--formula", FORMULA, "--trace", str(trace), "--all", "--format", "json"]
    return {
        "rmv eval": [python, "-m", "rmvdsl.cli", "eval", *options],
        "json.loads per line": [python, "-c", BARE_JSON, str(trace)],
        "whole trace in memory": [python, "-c", WHOLE_TRACE, str(trace), FORMULA],
    }


def run(samples: list[int], repeat: int, folder: Path) -> dict[str, Any]:
    rows: dict[str, Any] = {}
    for count in samples:
        trace = folder / f"braking-{count}.jsonl"
        # written by another process: a child forked from a parent holding the
        # samples would count them in its own peak memory
        subprocess.run([sys.executable, __file__, "--write", str(trace), str(count)], check=True)
        outputs: dict[str, str] = {}
        row: dict[str, Any] = {"bytes": trace.stat().st_size}
        for name, command in commands(trace).items():
            best = min(
                (measure(command, folder / f"{name}.out") for _ in range(repeat)),
                key=lambda m: m[0],
            )
            outputs[name] = (folder / f"{name}.out").read_text(encoding="utf-8")
            row[name] = {"seconds": best[0], "samples_per_s": count / best[0], "peak_mb": best[1]}
        streamed, whole = (
            json.loads(outputs["rmv eval"]),
            json.loads(outputs["whole trace in memory"]),
        )
        streamed["memory"].pop("held"), whole["memory"].pop("held")
        if streamed != whole:
            raise SystemExit("rmv eval and the whole-trace evaluation disagree: no figures")
        rows[str(count)] = row
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--samples", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", metavar="FILE")
    parser.add_argument("--write", nargs=2, metavar=("FILE", "SAMPLES"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.write:
        write_trace(Path(args.write[0]), int(args.write[1]))
        return 0
    with tempfile.TemporaryDirectory(prefix="rmv-bench-eval-") as folder:
        rows = run(args.samples, args.repeat, Path(folder))
    names = list(commands(Path("x")))
    print(f"formula 3.1 over the braking trace (JSON Lines), best of {args.repeat}; "
          "same segments from both evaluations")  # fmt: skip
    print(f"{'samples':>10} {'file MB':>8}" + "".join(f"{n + ' /s':>26}{'MB':>7}" for n in names))
    for count, row in rows.items():
        cells = "".join(
            f"{row[n]['samples_per_s']:>26,.0f}{row[n]['peak_mb']:>7.0f}" for n in names
        )
        print(f"{int(count):>10,} {row['bytes'] / 1e6:>8.1f}{cells}")
    if len(rows) > 1:
        small, large = rows[str(min(args.samples))], rows[str(max(args.samples))]
        growth = large["rmv eval"]["peak_mb"] / small["rmv eval"]["peak_mb"]
        print(f"rmv eval's peak memory, largest / smallest trace: {growth:.2f} (goal: flat)")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        payload = {"formula": FORMULA, "repeat": args.repeat, "rows": rows}
        Path(args.json).write_text(json.dumps(payload, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
