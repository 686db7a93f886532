"""`rmv replay` against rosbags' bare read and deserialise of the same recording.

Writes the CARLA braking scenario (examples/carla/make_recordings.py: 30 s of the
ego vehicle's status at 20 Hz and the objects around it at 10 Hz) repeated until the
recording holds --messages messages (1,000,000 by default: 9.3 hours), and a tenth of
it, in each storage (--storage: a ROS 1 .bag, a ROS 2 bag of SQLite .db3 files, one
of MCAP files; all three by default); then runs, each in its own process:

- bare:    rosbags' AnyReader reading and deserialising every message (the least any
           replay must do);
- replay:  `rmv replay examples/carla/abs.rmv RECORDING --format jsonl`, the whole
           spec (variables, continuous-query events, conditions, the transducer,
           three properties, alerts, intrusion detection), output to /dev/null;
           on two cores it reads the recording in a second process (docs/replay.md,
           "Two processes"), whose CPU time its own includes, and whose peak
           memory counts where it is the larger.

Before a speed is printed, both must have read the same number of messages (the
replay's `messages` counter) and the replay must report one ABSCheck violation per
30 s cycle. Each recording is measured in --rounds paired rounds (3 by default: the
bare read, then the replay). Reported: messages per second of each (median of the
rounds), the replay's speed as a fraction of the bare read's (goal: >= 100%) and its
CPU time's, each the median of the rounds' own ratios, and each process's peak
memory (RSS) on the tenth and on the whole recording. rosbags' reader keeps the
recording's index, so both grow with the recording; what the replay holds beyond
the bare read should be flat (the runtime holds what the spec's windows and
horizons need, not the recording).

    python benchmarks/bench_replay.py                      # 1,000,000 messages
    python benchmarks/bench_replay.py --messages 100000 --storage mcap --json out.json
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from statistics import median
from typing import IO, Any, TypeVar

sys.path.insert(0, str(Path(__file__).resolve().parent))

import peak
from as_installed import byte_compile

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "examples" / "carla" / "abs.rmv"
CYCLE_NS = 30 * 10**9
ROUNDS = 3
T = TypeVar("T")
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


STORAGES = ("bag", "db3", "mcap")  # ROS 1; ROS 2's SQLite and MCAP


def write_recording(path: Path, messages: int, storage: str = "bag") -> int:
    """The scenario repeated up to `messages` messages, as a ROS 1 bag or a ROS 2
    bag folder of `storage`; each cycle's messages are serialised once and written at
    shifted times. Returns the number of cycles begun."""
    from rosbags.rosbag1 import Writer as Bag1Writer
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Bag2Writer
    from rosbags.typesys import Stores

    scenario = _scenario()
    ros1 = storage == "bag"
    store = scenario.typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    cycle = [(t, topic, serialize(m, m.__msgtype__)) for t, topic, m in scenario.messages(store)]
    kinds = ((scenario.STATUS, scenario.STATUS_TYPE), (scenario.OBJECTS, scenario.OBJECTS_TYPE))
    _remove(path)
    if ros1:
        writer: Any = Bag1Writer(path)
        extra: dict[str, Any] = {"callerid": scenario.BRIDGE}
    else:
        plugin = StoragePlugin.SQLITE3 if storage == "db3" else StoragePlugin.MCAP
        writer, extra = Bag2Writer(path, version=9, storage_plugin=plugin), {}
    written = 0
    with writer:
        connections = {
            topic: writer.add_connection(topic, kind, typestore=store, **extra)
            for topic, kind in kinds
        }
        while written < messages:
            base = (written // len(cycle)) * CYCLE_NS
            for t, topic, data in cycle[: messages - written]:
                writer.write(connections[topic], base + t, data)
            written += min(len(cycle), messages - written)
    return -(-messages // len(cycle))


def _write_in_child(path: Path, messages: int, storage: str) -> int:
    """`write_recording` in a process of its own: a child's peak RSS counts the memory
    of the process it was started from, and writing a million messages grew this one
    to 1.3 GB (both measured processes then reported 1,301 MB)."""
    command = [sys.executable, __file__, "--write", str(path), str(messages), storage]
    return int(subprocess.run(command, check=True, capture_output=True, text=True).stdout)


def _remove(path: Path) -> None:
    if path.is_dir():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


def _size(path: Path) -> int:
    files = path.rglob("*") if path.is_dir() else [path]
    return sum(f.stat().st_size for f in files if f.is_file())


def _measure(command: list[str], read: Callable[[IO[str]], T]) -> tuple[float, peak.Usage, T]:
    """Wall time, what the process used (CPU, peak RSS: its own, benchmarks/peak.py)
    and what `read` makes of its standard output, read line by line (the
    million-message replay's output, read whole, was 1.3 GB)."""
    with tempfile.TemporaryFile("w+", encoding="utf-8") as out:
        start = time.perf_counter()
        usage = peak.run(command, stdout=out)
        elapsed = time.perf_counter() - start
        if usage.returncode not in (0, 1):
            raise SystemExit(f"{command[:4]} failed ({usage.returncode}): {usage.stderr}")
        out.seek(0)
        return elapsed, usage, read(out)


def _replay_output(out: IO[str]) -> tuple[dict[str, Any], int]:
    """The replay's counters, and how many times ABSCheck was violated."""
    counters, violations = {}, 0
    for line in out:
        record = json.loads(line)
        if record["kind"] == "counter":
            counters[record["name"]] = record["value"]
        elif record["kind"] == "verdict" and record["property"] == "ABSCheck":
            violations += record["verdict"] == "false"
    return counters, violations


def measure(path: Path, cycles: int, rounds: int = ROUNDS) -> dict[str, Any]:
    """`rounds` rounds, each the bare read then the replay, one after the other: the
    ratios are the medians of each round's own (a shared machine's load moves both
    of a round alike); speeds and memory are the medians of their rounds."""
    bare_runs, replay_runs = [], []
    replay = [sys.executable, "-m", "rmvdsl.cli", "replay", str(SPEC), str(path)]
    for _ in range(rounds):
        bare_runs.append(_measure([sys.executable, "-c", BARE, str(path)], _count_of))
        replay_runs.append(_measure([*replay, "--format", "jsonl"], _replay_output))
    count = bare_runs[0][2]
    for _, _, (counters, violations) in replay_runs:
        assert counters["messages"] == count, (counters["messages"], count)
        # one violation per full cycle (the second brake of each); a cut cycle may lack it
        assert cycles - 1 <= violations <= cycles, (violations, cycles)
    pairs = list(zip(bare_runs, replay_runs, strict=True))
    bare_time = median(b[0] for b in bare_runs)
    replay_time = median(r[0] for r in replay_runs)
    return {
        "messages": count,
        "rounds": rounds,
        "bare_seconds": bare_time,
        "bare_per_second": count / bare_time,
        "bare_cpu_seconds": median(b[1].cpu for b in bare_runs),
        "bare_peak_rss": int(median(b[1].peak_bytes for b in bare_runs)),
        "replay_seconds": replay_time,
        "replay_per_second": count / replay_time,
        "replay_cpu_seconds": median(r[1].cpu for r in replay_runs),
        "replay_peak_rss": int(median(r[1].peak_bytes for r in replay_runs)),
        "replay_fraction_of_bare": median(b[0] / r[0] for b, r in pairs),
        "replay_cpu_fraction_of_bare": median(b[1].cpu / r[1].cpu for b, r in pairs),
        "violations": replay_runs[0][2][1],
    }


def _count_of(out: IO[str]) -> int:
    return int(out.read())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--messages", type=int, default=1_000_000)
    parser.add_argument(
        "--storage", action="append", choices=STORAGES, help="bag, db3 or mcap (default: all)"
    )
    parser.add_argument("--json", help="write the figures to this file")
    parser.add_argument("--rounds", type=int, default=ROUNDS,
                        help=f"paired rounds of each recording (default {ROUNDS})")  # fmt: skip
    parser.add_argument("--write", nargs=3, metavar=("PATH", "MESSAGES", "STORAGE"),
                        help=argparse.SUPPRESS)  # fmt: skip
    args = parser.parse_args(argv)
    if args.write:  # a child of `_write_in_child`
        print(write_recording(Path(args.write[0]), int(args.write[1]), args.write[2]))
        return 0
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    byte_compile()
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="rmv-bench-replay-") as folder:
        # The solver's answers in a cache of this run's own (never the user's),
        # filled by a replay of one cycle first: a first replay also checks the spec,
        # which grew the first recording's peak RSS by 40 MB (and flatness is read
        # from the tenth against the whole).
        os.environ["RMV_CACHE_DIR"] = str(Path(folder) / "cache")
        warm = Path(folder) / "warm.bag"
        _write_in_child(warm, 1, "bag")
        _measure(
            [sys.executable, "-m", "rmvdsl.cli", "replay", str(SPEC), str(warm)], lambda out: None
        )
        for storage in args.storage or STORAGES:
            results[storage] = {}
            for label, count in (("tenth", args.messages // 10), ("whole", args.messages)):
                path = Path(folder) / (f"{label}.bag" if storage == "bag" else f"{label}_{storage}")
                print(f"writing {count:,} messages ({storage}) ...", file=sys.stderr)
                cycles = _write_in_child(path, count, storage)
                print(f"measuring {_size(path) / 1e6:,.0f} MB ...", file=sys.stderr)
                results[storage][label] = measure(path, cycles, args.rounds)
                _remove(path)
    columns = [
        ("storage", 7),
        ("recording", 10),
        ("messages", 10),
        ("bare msg/s", 11),
        ("replay msg/s", 13),
        ("replay/bare", 12),
        ("CPU", 5),
        ("bare RSS", 9),
        ("replay RSS", 11),
    ]
    print(" ".join(f"{name:>{width}}" for name, width in columns))
    for storage, rows in results.items():
        for label, r in rows.items():
            print(
                f"{storage:>7} {label:>10} {r['messages']:>10,} {r['bare_per_second']:>11,.0f} "
                f"{r['replay_per_second']:>13,.0f} {r['replay_fraction_of_bare']:>11.0%} "
                f"{r['replay_cpu_fraction_of_bare']:>5.0%} "
                f"{r['bare_peak_rss'] / 2**20:>7.0f}MB {r['replay_peak_rss'] / 2**20:>9.0f}MB"
            )
        whole, tenth = rows["whole"], rows["tenth"]
        # rosbags' reader holds the recording's index, which grows with its length in
        # both processes; what the replay holds beyond the bare read is the runtime's.
        own = [r["replay_peak_rss"] - r["bare_peak_rss"] for r in (tenth, whole)]
        print(
            f"{storage}: replay {whole['replay_fraction_of_bare']:.0%} of the bare read; "
            f"memory beyond it {own[0] / 2**20:.0f} MB on a tenth, "
            f"{own[1] / 2**20:.0f} MB on the whole recording (goal: flat)"
        )
        for result, extra in zip((tenth, whole), own, strict=True):
            result["replay_rss_beyond_bare"] = extra
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
