"""`rmv eval` end to end: samples per second and peak memory against the trace's length,
for traces as users write them.

The braking controller of bench_monitor.py at 100 Hz and formula 3.1, at 100,000 and
1,000,000 samples, written four ways: `plain` (`{"t": 12.34, "state": "A"}`, as
`rmv sat` and most examples write), `logger` (what a logging node writes: the
keys in a random order on every line, a sequence number on half the lines and a
17-digit float reading on a third, whole seconds as integers), `unix` (the plain
lines with Unix times in microseconds, 16 digits: `1700000012.340000`, as a ROS
stamp converted to seconds reads) and `csv` (`t,state,end` rows). Each command runs as
its own process (its start-up included); peak memory is the process's own maximum
resident set. In the same run, over the same file:

- `json.loads` per line (for `csv`, `csv.reader` per row): the standard library's
  reader, doing nothing with what it reads (the speed a tool starts from);
- `msgspec` per chunk: the reader `rmv eval` uses, bare (decode_lines into a typed
  record, 1 MB at a time; `rmv eval` decodes a chunk as one array, a line an item,
  which refuses two objects on a line), the floor under any reader built on it;
- `orjson` per line, where it is installed: the other fast reader measured;
- the whole trace in memory (plain only): the same monitor fed after reading the
  whole file into lists (how `rmv eval` worked before it streamed), same output;
- `rmv eval` as first typed, without `--all`: the verdict at 0, the trace read to
  its end (for `unix`, a time before the first sample: the reference evaluator's
  value, from the part of the trace within the formula's horizons).

`rmv eval`'s output is the same for every shape (checked; `unix`'s times less
1,700,000,000). Goals (issue 37): at least
1,000,000 samples a second end to end for any valid JSON Lines, memory flat in the
trace's length. Best of --repeat.

    python benchmarks/bench_eval.py [--json benchmarks/results/eval.json]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from fractions import Fraction
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import peak
from as_installed import byte_compile
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
from rmvdsl.logic.trace_lines import read_trace

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

MSGSPEC_CHUNKS = """
import sys
import msgspec

class Record(msgspec.Struct):
    t: float
    state: str | None = None
    end: bool | None = None

decoder, count = msgspec.json.Decoder(Record), 0
with open(sys.argv[1], "rb") as handle:
    rest = b""
    while chunk := handle.read(1 << 20):
        chunk = rest + chunk
        cut = chunk.rfind(b"\\n") + 1
        count += len(decoder.decode_lines(chunk[:cut]))
        rest = chunk[cut:]
    count += len(decoder.decode_lines(rest))
print(count)
"""
ORJSON = """
import sys
import orjson
count = 0
with open(sys.argv[1], "rb") as handle:
    for line in handle:
        orjson.loads(line)
        count += 1
print(count)
"""
BARE_CSV = """
import csv, sys
count = 0
with open(sys.argv[1], encoding="utf-8", newline="") as handle:
    for row in csv.reader(handle):
        count += 1
print(count)
"""
SHAPES = ("plain", "logger", "unix", "csv")
EPOCH = 1_700_000_000  # the unix shape's first time


def write_trace(path: Path, samples: int, shape: str) -> None:
    draw = random.Random(37)
    with path.open("w", encoding="utf-8") as handle:
        if shape == "csv":
            handle.write("t,state,end\n")
        for tick, state in generate(samples):
            time = f"{tick // 100}.{tick % 100:02d}"
            if shape == "csv":
                handle.write(f"{time},{state},\n")
                continue
            if shape == "plain":
                handle.write(f'{{"t": {time}, "state": "{state}"}}\n')
                continue
            if shape == "unix":
                handle.write(
                    f'{{"t": {EPOCH + tick // 100}.{tick % 100:02d}0000, "state": "{state}"}}\n'
                )
                continue
            fields = [f'"t": {tick // 100 if tick % 100 == 0 else time}', f'"state": "{state}"']
            if draw.random() < 0.5:
                fields.append(f'"seq": {tick}')
            if draw.random() < 0.3:
                fields.append(f'"speed": {draw.random() * 30!r}')
            draw.shuffle(fields)
            handle.write("{" + ", ".join(fields) + "}\n")
        start = EPOCH if shape == "unix" else 0
        end = f"{start + samples // 100}.{samples % 100:02d}"
        handle.write(f"{end},,true\n" if shape == "csv" else f'{{"t": {end}, "end": true}}\n')


def measure(command: list[str], output: Path) -> tuple[float, float]:
    """Wall seconds and peak resident MB of one process (its own: benchmarks/peak.py)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with output.open("w") as out:
        start = time.perf_counter()
        usage = peak.run(command, stdout=out, env=env, cwd=ROOT)
        seconds = time.perf_counter() - start
    if usage.returncode:
        raise SystemExit(f"{command[:4]} failed with status {usage.returncode}: {usage.stderr}")
    return seconds, usage.peak_bytes / 2**20


def commands(trace: Path, shape: str) -> dict[str, list[str]]:
    python = sys.executable
    options = ["--formula", FORMULA, "--trace", str(trace), "--all", "--format", "json"]
    found = {
        "rmv eval": [python, "-m", "rmvdsl.cli", "eval", *options],
        # the command as first typed: the verdict at 0 (for `unix`, before the first
        # sample, which the reference evaluator gives from the trace's first horizon)
        "rmv eval at 0": [python, "-m", "rmvdsl.cli", "eval", *options[:4]],
    }
    if shape == "csv":  # the standard library's reader is the baseline
        found["csv.reader per row"] = [python, "-c", BARE_CSV, str(trace)]
        return found
    found["json.loads per line"] = [python, "-c", BARE_JSON, str(trace)]
    found["msgspec per chunk"] = [python, "-c", MSGSPEC_CHUNKS, str(trace)]
    if importlib.util.find_spec("orjson") is not None:
        found["orjson per line"] = [python, "-c", ORJSON, str(trace)]
    if shape == "plain":
        found["whole trace in memory"] = [python, "-c", WHOLE_TRACE, str(trace), FORMULA]
    return found


def run(samples: list[int], repeat: int, folder: Path) -> dict[str, Any]:
    rows: dict[str, Any] = {}
    for count in samples:
        outputs: dict[str, str] = {}
        for shape in SHAPES:
            trace = folder / f"braking-{count}-{shape}.jsonl"
            # written by another process: a child forked from a parent holding the
            # samples would count them in its own peak memory
            subprocess.run(
                [sys.executable, __file__, "--write", str(trace), str(count), shape], check=True
            )
            row: dict[str, Any] = {"bytes": trace.stat().st_size}
            for name, command in commands(trace, shape).items():
                out = folder / f"{shape}-{name}.out"
                best = min((measure(command, out) for _ in range(repeat)), key=lambda m: m[0])
                outputs[f"{shape} {name}"] = out.read_text(encoding="utf-8")
                row[name] = {"seconds": best[0], "samples_per_s": count / best[0],
                             "peak_mb": best[1]}  # fmt: skip
            baseline = row["csv.reader per row" if shape == "csv" else "json.loads per line"]
            row["rmv eval / the standard library's reader"] = (
                row["rmv eval"]["samples_per_s"] / baseline["samples_per_s"]
            )
            trace.unlink()
            rows[f"{count} {shape}"] = row
        compared = ("plain rmv eval", "logger rmv eval", "plain whole trace in memory",
                    "unix rmv eval", "csv rmv eval")  # fmt: skip
        evaluated = [json.loads(outputs[key]) for key in compared]
        for result in evaluated:
            result["memory"].pop("held")
        shift(evaluated[3], -EPOCH)
        if any(result != evaluated[0] for result in evaluated):
            raise SystemExit("the evaluations of the shapes disagree: no figures")
    return rows


def shift(result: dict[str, Any], by: int) -> None:
    """An evaluation's segment times moved by `by`, exactly (as JSON writes them)."""
    for segment in [*result["segments"], *result["beyond"]]:
        for key in ("from", "to"):
            if segment[key] is not None:
                moved = Fraction(str(segment[key])) + by
                segment[key] = int(moved) if moved.denominator == 1 else float(moved)


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--samples", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", metavar="FILE")
    parser.add_argument("--write", nargs=3, metavar=("FILE", "SAMPLES", "SHAPE"),
                        help=argparse.SUPPRESS)  # fmt: skip
    args = parser.parse_args()
    if args.write:
        write_trace(Path(args.write[0]), int(args.write[1]), args.write[2])
        return 0
    byte_compile()
    with tempfile.TemporaryDirectory(prefix="rmv-bench-eval-") as folder:
        rows = run(args.samples, args.repeat, Path(folder))
    print(f"formula 3.1 over the braking trace (JSON Lines), samples per second, best of "
          f"{args.repeat}; the same segments from every evaluation")  # fmt: skip
    for key, row in rows.items():
        cells = ", ".join(
            f"{name} {value['samples_per_s']:,.0f} ({value['peak_mb']:.0f} MB)"
            for name, value in row.items()
            if isinstance(value, dict)
        )
        ratio = row["rmv eval / the standard library's reader"]
        print(f"{key} ({row['bytes'] / 1e6:.1f} MB): {cells}; rmv eval / the standard "
              f"library's reader {ratio:.2f}")  # fmt: skip
    largest, smallest = max(args.samples), min(args.samples)
    if largest != smallest:
        for shape in SHAPES:
            growth = (rows[f"{largest} {shape}"]["rmv eval"]["peak_mb"]
                      / rows[f"{smallest} {shape}"]["rmv eval"]["peak_mb"])  # fmt: skip
            print(f"rmv eval's peak memory, {shape}, largest / smallest trace: {growth:.2f}")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        payload = {"formula": FORMULA, "repeat": args.repeat, "rows": rows}
        Path(args.json).write_text(json.dumps(payload, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
