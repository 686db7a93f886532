"""Decoding a recording's messages: rosbags' full decoder against the reader of only
the fields a spec reads (rmvdsl.host.partial_decoding), as `rmv replay` calls each.

Writes the CARLA braking scenario (bench_replay.py's recording) to --messages
messages in each storage (a ROS 1 .bag, ROS 2 .db3 and .mcap), then, in a process of
its own per storage, reads every message's bytes once and times decoding them all
(best of --repeat passes) both ways through `rmvdsl.tools.recordings.decoder`: with no
fields named (the full decoder) and with examples/carla/abs.rmv's fields. Before a
figure is printed, every variable of the spec must read the same value from both
decodings of every message. Reported per message type: microseconds a message each
way and their ratio (figures in benchmarks/results/decoding.json).

    python benchmarks/bench_decoding.py [--messages 20000] [--json out.json]
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

from bench_replay import ROOT, SPEC, STORAGES, _write_in_child


def timed(path: str, repeat: int) -> dict[str, Any]:
    """In this process: each message type's decoding, full and partial (µs a message)."""
    from rosbags.highlevel import AnyReader

    from rmvdsl.check import check
    from rmvdsl.host.partial_decoding import spec_needs
    from rmvdsl.ir import lower
    from rmvdsl.runtime import fields
    from rmvdsl.tools import recordings

    spec = lower(check(str(SPEC)))
    with AnyReader([Path(path)]) as reader:
        messages = [(connection, bytes(raw)) for connection, _, raw in reader.messages()]
        ways = {
            "full": recordings.decoder(reader, {}),
            "partial": recordings.decoder(reader, spec_needs(spec)),
        }
        topics = {t.name: t.ros_name for t in spec.topics}
        readers = [(topics[v.topic], fields.reader(v)) for v in spec.variables]
        for connection, raw in messages:  # the same values both ways, or no figure
            full, partial = (way(connection, raw) for way in ways.values())
            for topic, read in readers:
                if topic == connection.topic:
                    assert read(full) == read(partial), (
                        connection.topic,
                        read(full),
                        read(partial),
                    )
        out: dict[str, Any] = {}
        for msgtype in sorted({c.msgtype for c, _ in messages}):
            mine = [(c, raw) for c, raw in messages if c.msgtype == msgtype]
            row: dict[str, Any] = {"messages": len(mine)}
            for name, decode in ways.items():
                best = min(_pass(decode, mine) for _ in range(repeat))
                row[f"{name}_us"] = best / len(mine) * 1e6
            row["partial_of_full"] = row["partial_us"] / row["full_us"]
            out[msgtype] = row
    return out


def _pass(decode: Any, messages: list[tuple[Any, bytes]]) -> float:
    start = time.perf_counter()
    for connection, raw in messages:
        decode(connection, raw)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--messages", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", help="write the figures to this file")
    parser.add_argument("--timed", help=argparse.SUPPRESS)  # a child: the recording to time
    args = parser.parse_args(argv)
    if args.timed:
        print(json.dumps(timed(args.timed, args.repeat)))
        return 0
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="rmv-bench-decoding-") as folder:
        os.environ["RMV_CACHE_DIR"] = str(Path(folder) / "cache")
        for storage in STORAGES:
            path = Path(folder) / ("run.bag" if storage == "bag" else f"run_{storage}")
            _write_in_child(path, args.messages, storage)
            child = [sys.executable, __file__, "--timed", str(path), "--repeat", str(args.repeat)]
            done = subprocess.run(child, check=True, capture_output=True, text=True)
            results[storage] = json.loads(done.stdout)
    print(f"{'storage':>7} {'message type':>40} {'full µs':>9} {'partial µs':>11} {'ratio':>6}")
    for storage, rows in results.items():
        for msgtype, row in rows.items():
            print(f"{storage:>7} {msgtype:>40} {row['full_us']:>9.1f} {row['partial_us']:>11.1f} "
                  f"{row['partial_of_full']:>6.2f}")  # fmt: skip
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
