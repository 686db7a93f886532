"""`rmv replay` of a short recording, where starting is most of the work: the
example's 30 s braking recording (examples/carla/recordings: 900 messages, in each
storage) replayed by `examples/carla/abs.rmv`, as new processes, beside rosbags'
bare read and deserialisation of the same recording:

- bare:    rosbags' AnyReader reading and deserialising every message;
- checked: `rmv replay` with no stored spec: it checks the spec first (the
           solver's answers already cached, as after any earlier check of it);
- stored:  `rmv replay` of the unchanged spec again: the IR its last clean check
           stored is loaded (rmvdsl.commands.stored_spec), no checker imported.

Each is run `--repeat` times, interleaved, in a cache folder of this run's own;
reported: the median wall and CPU seconds of each, and each replay's against the
bare read of the same round (the machine is shared: read the ratios). Then `rmv
build --target ros2` of the same spec, checking and from the stored spec, in
rounds the same way (a build shares the replay's stored spec).

    python benchmarks/bench_replay_start.py --json benchmarks/results/replay_start.json
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import peak
from as_installed import byte_compile
from bench_replay import BARE

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "examples" / "carla" / "abs.rmv"
RECORDINGS = ROOT / "examples" / "carla" / "recordings"
STORAGES = {"bag": "braking.bag", "db3": "braking_db3", "mcap": "braking_mcap"}


def _run(command: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of one process (its own: benchmarks/peak.py; the wall
    time holds the launcher's start too, alike for every command)."""
    start = time.perf_counter()
    usage = peak.run(command, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    if usage.returncode not in (0, 1):  # 1: the recording's violation
        raise SystemExit(f"{command[:4]} failed ({usage.returncode}): {usage.stderr}")
    return wall, usage.cpu


def measure(recording: Path, cache: Path, repeat: int) -> dict[str, Any]:
    replay = [sys.executable, "-m", "rmvdsl.cli", "replay", str(SPEC), str(recording),
              "--format", "jsonl", "--quiet"]  # fmt: skip
    runs: dict[str, list[tuple[float, float]]] = {"bare": [], "checked": [], "stored": []}
    for _ in range(repeat):
        runs["bare"].append(_run([sys.executable, "-c", BARE, str(recording)]))
        shutil.rmtree(cache / "checks", ignore_errors=True)  # the answers stay
        runs["checked"].append(_run(replay))
        runs["stored"].append(_run(replay))
    out = _medians(runs)
    for name in ("checked", "stored"):
        ratios = [r[0] / b[0] for r, b in zip(runs[name], runs["bare"], strict=True)]
        out[f"{name}_over_bare"] = statistics.median(ratios)
    return out


def measure_build(cache: Path, out: Path, repeat: int) -> dict[str, Any]:
    """`rmv build --target ros2` checking the spec and from its stored IR."""
    build = [sys.executable, "-m", "rmvdsl.cli", "build", str(SPEC), "--target", "ros2",
             "-o", str(out)]  # fmt: skip
    runs: dict[str, list[tuple[float, float]]] = {"checked": [], "stored": []}
    for _ in range(repeat):
        shutil.rmtree(cache / "checks", ignore_errors=True)
        runs["checked"].append(_run(build))
        runs["stored"].append(_run(build))
    return _medians(runs)


def _medians(runs: dict[str, list[tuple[float, float]]]) -> dict[str, Any]:
    """Each command's median wall and CPU seconds, and the median of each round's
    wall time from the stored spec against the one checking it."""
    out: dict[str, Any] = {}
    for name, values in runs.items():
        out[f"{name}_wall"] = statistics.median(w for w, _ in values)
        out[f"{name}_cpu"] = statistics.median(c for _, c in values)
    out["stored_over_checked"] = statistics.median(
        s[0] / c[0] for s, c in zip(runs["stored"], runs["checked"], strict=True)
    )
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    byte_compile()  # as an install holds rmvdsl: compiled
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    results: dict[str, Any] = {"repeat": args.repeat}
    with tempfile.TemporaryDirectory(prefix="rmv-bench-start-") as folder:
        cache = Path(folder) / "cache"
        os.environ["RMV_CACHE_DIR"] = str(cache)
        _run([sys.executable, "-m", "rmvdsl.cli", "check", str(SPEC)])  # the answers
        for storage, name in STORAGES.items():
            row = results[storage] = measure(RECORDINGS / name, cache, args.repeat)
            print(
                f"{storage:>5}: bare {row['bare_wall']:.2f} s, replay checking the spec "
                f"{row['checked_wall']:.2f} s ({row['checked_over_bare']:.1f}x), from the "
                f"stored spec {row['stored_wall']:.2f} s ({row['stored_over_bare']:.1f}x)"
            )
        row = results["build"] = measure_build(cache, Path(folder) / "package", args.repeat)
        print(f"build: checking the spec {row['checked_wall']:.2f} s, from the stored spec "
              f"{row['stored_wall']:.2f} s ({row['stored_over_checked']:.0%})")  # fmt: skip
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
