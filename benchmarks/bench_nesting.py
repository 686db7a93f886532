"""Nested windows against flat ones, as users meet them: new processes (issue 37).

N properties (default 2,000), each over its own event `x > k`, written two ways with
one meaning: `flat` (`eventually[<=10s] Ek`) and `nested` (ten nested
`eventually[<=1s]`). For each spec, in turn within each round: the first check (an
empty cache), a check after an edit (a comment added; the answers cached), and a
replay of a recording of 600 messages on /t. The flat spec is the baseline, run in
the same process tree, round by round; the figures are medians of the per-round
ratios nested/flat of CPU seconds (the machine is shared: ratios, not seconds, are
the figures to read). Goal: each within 2x. The two replays' verdicts are checked
equal.

    python benchmarks/bench_nesting.py [--properties N] [--rounds R] \\
        [--json benchmarks/results/nesting.json]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HEAD = 'system many\ntopic t: std_msgs/msg/Float64 = "/t"\nvar x = t.data\n'
MESSAGES = 600
STEPS = ("first check", "check after an edit", f"replay of {MESSAGES} messages")


def specs(count: int) -> dict[str, str]:
    events = "".join(f"event E{k} when x > {k}\n" for k in range(count))

    def nested(k: int) -> str:
        formula = f"E{k}"
        for _ in range(10):
            formula = f"eventually[<=1s] ({formula})"
        return f"property P{k}: {formula}\n"

    flat = "".join(f"property P{k}: eventually[<=10s] E{k}\n" for k in range(count))
    return {
        "flat": HEAD + events + flat,
        "nested": HEAD + events + "".join(nested(k) for k in range(count)),
    }


def write_recording(folder: Path, count: int) -> Path:
    """MESSAGES values of x on /t, 10 Hz, crossing many of the events' thresholds."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    kind = store.types["std_msgs/msg/Float64"]
    path = folder / "recording"
    with Writer(path, version=8) as writer:
        connection = writer.add_connection("/t", kind.__msgtype__, typestore=store)
        for k in range(MESSAGES):
            data = store.serialize_cdr(kind(data=float((k * 37) % (count + 100))), kind.__msgtype__)
            writer.write(connection, 10**9 + k * 10**8, data)
    return path


def child(command: list[str], cache: Path) -> tuple[float, float, str]:
    """Wall and CPU seconds of one new process, and what it printed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True,
                          env={**os.environ, "RMV_CACHE_DIR": str(cache)})  # fmt: skip
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{command[2:5]} failed: {done.stdout[-2000:]}{done.stderr[-2000:]}")
    return wall, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, done.stdout


def one_round(folder: Path, texts: dict[str, str], recording: Path) -> dict[str, Any]:
    rmv = [sys.executable, "-m", "rmvdsl.cli"]
    out: dict[str, Any] = {}
    replays = {}
    for name, text in texts.items():
        spec, cache = folder / f"{name}.rmv", folder / f"cache-{name}"
        shutil.rmtree(cache, ignore_errors=True)
        spec.write_text(text, encoding="utf-8")
        first = child([*rmv, "check", str(spec)], cache)
        spec.write_text(text + "// an edit\n", encoding="utf-8")
        edited = child([*rmv, "check", str(spec)], cache)
        replay = child([*rmv, "replay", str(spec), str(recording)], cache)
        replays[name] = replay[2]
        steps = zip(STEPS, (first, edited, replay), strict=True)
        out[name] = {step: {"wall": w, "cpu": c} for step, (w, c, _) in steps}
    if replays["flat"] != replays["nested"]:
        raise SystemExit("the two replays' verdicts differ")
    return out


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--properties", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args()
    texts = specs(args.properties)
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        recording = write_recording(folder, args.properties)
        rounds = []
        for number in range(args.rounds):
            rounds.append(one_round(folder, texts, recording))
            print(f"round {number + 1} of {args.rounds} done", file=sys.stderr)
    figures: dict[str, Any] = {"properties": args.properties, "rounds": args.rounds}
    print(f"{'':24} {'flat cpu':>9} {'nested cpu':>11} {'nested/flat':>12}")
    for step in STEPS:
        flat = statistics.median(r["flat"][step]["cpu"] for r in rounds)
        nested = statistics.median(r["nested"][step]["cpu"] for r in rounds)
        ratio = statistics.median(r["nested"][step]["cpu"] / r["flat"][step]["cpu"] for r in rounds)
        figures[step] = {"flat_cpu": flat, "nested_cpu": nested, "ratio": ratio}
        print(f"{step:24} {flat:>8.2f}s {nested:>10.2f}s {ratio:>11.2f}x")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
