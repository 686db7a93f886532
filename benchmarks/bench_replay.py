"""`rmv replay` against rosbags' bare read and deserialise of the same recording.

Writes the CARLA braking scenario (examples/carla/make_recordings.py: 30 s of the
ego vehicle's status at 20 Hz and the objects around it at 10 Hz) repeated until the
recording holds --messages messages (1,000,000 by default: 9.3 hours), as a ROS 1
bag, and a tenth of it; then runs, each in its own process:

- bare:    rosbags' AnyReader reading and deserialising every message (the least any
           replay must do);
- replay:  `rmv replay examples/carla/abs.rmv RECORDING --format jsonl`, the whole
           spec (variables, continuous-query events, conditions, the transducer,
           three properties, alerts, intrusion detection), output to /dev/null.

Before a speed is printed, both must have read the same number of messages (the
replay's `messages` counter) and the replay must report one ABSCheck violation per
30 s cycle. Reported: messages per second of each, the replay's speed as a fraction
of the bare read's (goal: >= 30%), and each process's peak memory (RSS) on the tenth
and on the whole recording. rosbags' reader keeps the recording's index, so both
grow with the recording; what the replay holds beyond the bare read should be flat
(the runtime holds what the spec's windows and horizons need, not the recording).

    python benchmarks/bench_replay.py                      # 1,000,000 messages
    python benchmarks/bench_replay.py --messages 100000 --json out.json
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "examples" / "carla" / "abs.rmv"
CYCLE_NS = 30 * 10**9
BARE = """
import sys
from pathlib import Path
from rosbags.highlevel import AnyReader
count = 0
with AnyReader([Path(sys.argv[1])]) as reader:
    for connection, _, raw in reader.messages():
        reader.deserialize(raw, connection.msgtype)
        count += 1
print(count)
"""


def _scenario() -> Any:
    spec = importlib.util.spec_from_file_location(
        "make_recordings", ROOT / "examples" / "carla" / "make_recordings.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_recording(path: Path, messages: int) -> int:
    """The scenario repeated up to `messages` messages; each cycle's messages are
    serialised once and written at shifted times. Returns the number of cycles
    begun."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores

    scenario = _scenario()
    store = scenario.typestore(Stores.ROS1_NOETIC)
    cycle = [
        (t, topic, store.serialize_ros1(m, m.__msgtype__))
        for t, topic, m in scenario.messages(store)
    ]
    path.unlink(missing_ok=True)
    written = 0
    with Writer(path) as writer:
        kinds = ((scenario.STATUS, scenario.STATUS_TYPE), (scenario.OBJECTS, scenario.OBJECTS_TYPE))
        connections = {
            topic: writer.add_connection(topic, kind, typestore=store, callerid=scenario.BRIDGE)
            for topic, kind in kinds
        }
        while written < messages:
            base = (written // len(cycle)) * CYCLE_NS
            for t, topic, data in cycle[: messages - written]:
                writer.write(connections[topic], base + t, data)
            written += min(len(cycle), messages - written)
    return -(-messages // len(cycle))


def _measure(command: list[str]) -> tuple[float, int, str]:
    """Wall time, peak RSS (bytes) and standard output of one process."""
    with tempfile.TemporaryFile() as out:
        start = time.perf_counter()
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(process.pid, 0)
        elapsed = time.perf_counter() - start
        process.returncode = os.waitstatus_to_exitcode(status)
        error = process.stderr.read().decode() if process.stderr else ""
        out.seek(0)
        text = out.read().decode()
    if process.returncode not in (0, 1):
        raise SystemExit(f"{command[:4]} failed ({process.returncode}): {error}")
    return elapsed, usage.ru_maxrss * 1024, text


def measure(path: Path, cycles: int) -> dict[str, Any]:
    bare_time, bare_rss, bare_out = _measure([sys.executable, "-c", BARE, str(path)])
    count = int(bare_out)
    replay = [sys.executable, "-m", "rmvdsl.cli", "replay", str(SPEC), str(path)]
    replay_time, replay_rss, replay_out = _measure([*replay, "--format", "jsonl"])
    records = [json.loads(line) for line in replay_out.splitlines()]
    counters = {r["name"]: r["value"] for r in records if r["kind"] == "counter"}
    violations = [
        r for r in records
        if r["kind"] == "verdict" and r["property"] == "ABSCheck" and r["verdict"] == "false"
    ]  # fmt: skip
    assert counters["messages"] == count, (counters["messages"], count)
    # one violation per full cycle (the second brake of each); a cut cycle may lack it
    assert cycles - 1 <= len(violations) <= cycles, (len(violations), cycles)
    return {
        "messages": count,
        "bare_seconds": bare_time,
        "bare_per_second": count / bare_time,
        "bare_peak_rss": bare_rss,
        "replay_seconds": replay_time,
        "replay_per_second": count / replay_time,
        "replay_peak_rss": replay_rss,
        "replay_fraction_of_bare": bare_time / replay_time,
        "violations": len(violations),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--messages", type=int, default=1_000_000)
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    results = {}
    with tempfile.TemporaryDirectory(prefix="rmv-bench-replay-") as folder:
        # The solver's answers in a cache of this run's own (never the user's): the
        # first replay fills it, as a user's first replay of a spec does.
        os.environ["RMV_CACHE_DIR"] = str(Path(folder) / "cache")
        for label, count in (("tenth", args.messages // 10), ("whole", args.messages)):
            path = Path(folder) / f"{label}.bag"
            print(f"writing {count:,} messages ...", file=sys.stderr)
            cycles = write_recording(path, count)
            print(f"measuring {path.stat().st_size / 1e6:,.0f} MB ...", file=sys.stderr)
            results[label] = measure(path, cycles)
            path.unlink()
    print(f"{'recording':>10} {'messages':>10} {'bare msg/s':>11} {'replay msg/s':>13} "
          f"{'replay/bare':>12} {'bare RSS':>9} {'replay RSS':>11}")  # fmt: skip
    for label, r in results.items():
        print(
            f"{label:>10} {r['messages']:>10,} {r['bare_per_second']:>11,.0f} "
            f"{r['replay_per_second']:>13,.0f} {r['replay_fraction_of_bare']:>11.0%} "
            f"{r['bare_peak_rss'] / 2**20:>7.0f}MB {r['replay_peak_rss'] / 2**20:>9.0f}MB"
        )
    whole, tenth = results["whole"], results["tenth"]
    # rosbags' reader holds the recording's index, which grows with its length in
    # both processes; what the replay holds beyond the bare read is the runtime's.
    own = [r["replay_peak_rss"] - r["bare_peak_rss"] for r in (tenth, whole)]
    print(f"replay speed: {whole['replay_fraction_of_bare']:.0%} of the bare read (goal >= 30%)")
    print(
        f"replay memory beyond the bare read: {own[0] / 2**20:.0f} MB on a tenth, "
        f"{own[1] / 2**20:.0f} MB on the whole recording (goal: flat)"
    )
    for result, extra in zip((tenth, whole), own, strict=True):
        result["replay_rss_beyond_bare"] = extra
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
