"""Fleet replay (docs/fleet.md): recordings a second and messages a second of
`rmv replay` over a fleet, as whole processes, in one run:

- sequential: `--jobs 1`, every recording in the command's own process (the
  baseline: what one core does);
- jobs 2:     `--jobs 2`, two worker processes;
- dask 2:     `--scheduler` on a LocalCluster of two one-thread worker processes,
              bound to 127.0.0.1, started here once (not timed).

and on one long recording of --long-messages (--long-messages / 10 s on the clock):

- one run:    `--jobs 1`, the recording in one run (the baseline);
- chunks 2:   `--chunk` of an eighth of it and `--jobs 2`: eight chunks in two
              worker processes, joined into the one run's result (checked here).

Each is run --repeats times, alternating, and the medians are compared. Reported:
the speed-up of --jobs 2 and its scaling efficiency (speed-up / 2: the goal is
>= 0.8 on this 2-core machine for recordings of >= 10^5 messages), the Dask path's
time against --jobs 2 on the same work, and each worker's peak memory (VmHWM,
sampled from /proc while it runs) on recordings of --messages and of a tenth of
that: flat means a worker holds what the spec needs, not the recording.

The fleet: --count recordings (tests/fleet_recordings.py: a robot's speed, the
three formats in turn) of --messages each.

    python benchmarks/bench_fleet.py                          # 8 x 100,000 messages
    python benchmarks/bench_fleet.py --count 4 --messages 20000 --json out.json
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
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
import fleet_recordings  # noqa: E402

RMV = [shutil.which("rmv") or "rmv"]


def _peak_memory(pid: int, stop: threading.Event, peaks: dict[int, int]) -> None:
    """Each descendant's peak resident memory (kB), sampled until `stop`."""
    while not stop.is_set():
        for child in _descendants(pid):
            try:
                status = Path(f"/proc/{child}/status").read_text()
            except OSError:
                continue
            for line in status.splitlines():
                if line.startswith("VmHWM:"):
                    peaks[child] = max(peaks.get(child, 0), int(line.split()[1]))
        stop.wait(0.1)


def _descendants(pid: int) -> list[int]:
    parents: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        parents.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, todo = [], [pid]
    while todo:
        for child in parents.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def run(args: list[str], cwd: Path, watch: int | None = None) -> dict[str, Any]:
    """One `rmv replay` process: its wall time, its results, its workers' peaks.
    `watch`: also sample this process's descendants (a LocalCluster's workers)."""
    began = time.perf_counter()
    process = subprocess.Popen([*RMV, "replay", *args, "--format", "jsonl", "--quiet"], cwd=cwd,
                               stdout=subprocess.PIPE, text=True)  # fmt: skip
    peaks: dict[int, int] = {}
    stop = threading.Event()
    sampler = threading.Thread(target=_peak_memory, args=(watch or process.pid, stop, peaks))
    sampler.start()
    out, _ = process.communicate()
    wall = time.perf_counter() - began
    stop.set()
    sampler.join()
    results = [json.loads(line) for line in out.splitlines()]
    assert process.returncode in (0, 1), f"rmv replay exited {process.returncode}"
    return {"wall": wall, "results": results, "peaks_kb": sorted(peaks.values())}


def summary(results: list[dict[str, Any]]) -> list[tuple[str, str, int]]:
    return sorted((r["path"], r["status"], r["violations"]) for r in results)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=8)
    parser.add_argument("--messages", type=int, default=100_000)
    parser.add_argument("--long-messages", type=int, default=400_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    from distributed import LocalCluster

    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        (folder / "spec.rmv").write_text(fleet_recordings.SPEC, encoding="utf-8")
        fleet_recordings.fleet(folder / "long", args.count, args.messages)
        fleet_recordings.fleet(folder / "short", args.count, args.messages // 10)
        one = folder / "one"
        one.mkdir()
        fleet_recordings.write(one / "long", "mcap", fleet_recordings.speeds(5, args.long_messages))
        chunk = f"{args.long_messages / 10 / 8:g}"  # seconds: 10 messages a second
        total = args.count * args.messages
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster:  # fmt: skip
            ways = {
                # A pattern: one result, as for a fleet, from the command's own process.
                "one run": (["spec.rmv", "one/long_*", "--jobs", "1"], None),
                "chunks 2": (["spec.rmv", "one/long_*", "--chunk", chunk, "--jobs", "2"], None),
                "sequential": (["spec.rmv", "long", "--jobs", "1"], None),
                "jobs 2": (["spec.rmv", "long", "--jobs", "2"], None),
                "dask 2": (
                    ["spec.rmv", "long", "--scheduler", cluster.scheduler_address],
                    os.getpid(),
                ),
            }
            walls: dict[str, list[float]] = {name: [] for name in ways}
            peaks: dict[str, list[int]] = {}
            first: dict[str, Any] = {}
            for repeat in range(args.repeats):
                for name, (command, watch) in ways.items():
                    done = run(command, folder, watch)
                    walls[name].append(done["wall"])
                    first.setdefault(name, done["results"] if "one" in command[1] else
                                     summary(done["results"]))  # fmt: skip
                    peaks.setdefault(name, done["peaks_kb"])
                    print(f"  {repeat + 1}/{args.repeats} {name}: {done['wall']:.2f} s", flush=True)
            short = run(["spec.rmv", "short", "--jobs", "2"], folder)
    assert first["jobs 2"] == first["sequential"] == first["dask 2"], "results differ"
    whole, joined = first["one run"][0], first["chunks 2"][0]
    assert sorted(map(json.dumps, whole["records"])) == sorted(map(json.dumps, joined["records"]))
    median = {name: statistics.median(times) for name, times in walls.items()}
    speedup = median["sequential"] / median["jobs 2"]
    chunked = median["one run"] / median["chunks 2"]
    figures = {
        "recordings": args.count,
        "messages_each": args.messages,
        "repeats": args.repeats,
        "median_wall_s": {k: round(v, 3) for k, v in median.items()},
        "recordings_per_s": {
            k: round(args.count / v, 2)
            for k, v in median.items()
            if k in ("sequential", "jobs 2", "dask 2")
        },
        "messages_per_s": {
            k: round((args.long_messages if k in ("one run", "chunks 2") else total) / v)
            for k, v in median.items()
        },
        "jobs2_speedup": round(speedup, 3),
        "jobs2_scaling_efficiency": round(speedup / 2, 3),
        "dask2_over_jobs2": round(median["dask 2"] / median["jobs 2"], 3),
        "long_recording_messages": args.long_messages,
        "chunks2_speedup": round(chunked, 3),
        "chunks2_scaling_efficiency": round(chunked / 2, 3),
        "chunks2_seams_read_past": joined["seams_read_past"],
        "jobs2_worker_peak_kb": {"long": peaks["jobs 2"][-2:], "tenth": short["peaks_kb"][-2:]},
        "cpus": os.cpu_count(),
    }
    print(json.dumps(figures, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
