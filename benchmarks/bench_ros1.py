"""The generated ROS 1 monitor (rospy, AnyMsg, decoded with rosbags) against a bare
rospy AnyMsg subscriber, on Debian's ROS 1, every process inside a private network
namespace holding only loopback with a roscore of its own. Each reader is its own
process; the load is another (benchmarks/ros1_load.py):

- rate:     COUNT messages sent at once to formula 3.1 (its transducer, sampled at
            10 Hz as abs.rmv does), beside the bare subscriber that only counts:
            messages per second of wall time and per CPU second of the reader
            (goal: the monitor >= 60% of the bare one);
- latency:  at 100 Hz and 1 kHz, from sending a message to receiving the verdict
            segment it completes on /rmv/verdicts, beside the bare subscriber's echo
            (goal: p99 <= 2 ms);
- workload: the thesis's rate (table 4.1: 18,391 messages in 100 s) on the two
            topics abs.rmv reads, the CARLA recording's messages repeated in a bag
            played by `rosbag play`: the node's CPU share of one core, peak memory.

Before a figure is printed, every message must have been read (the node's
counters: none lost, none late, none damaged).

    python benchmarks/bench_ros1.py [--seconds 100] [--count 5000]
    python benchmarks/bench_ros1.py --json benchmarks/results/ros1.json

`--soak SECONDS` runs only the soak on ROS 1 (tests/ros1/drive_soak.py on
tests/ros1/soak.rmv's nodes; the test suite runs 60 s of it), judged as
bench_ros2.py's: allowed nodes coming and going, rogues injected, verdicts against a
replay of what was sent, memory after warm-up:

    python benchmarks/bench_ros1.py --soak 600 --json benchmarks/results/soak_ros1.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "ros1"))
import bench_ros2  # noqa: E402
import rosenv1  # noqa: E402

from rmvdsl.check import check  # noqa: E402
from rmvdsl.ir import lower  # noqa: E402
from rmvdsl.targets import target  # noqa: E402

LOAD = Path(__file__).resolve().parent / "ros1_load.py"
CARLA = ROOT / "examples" / "carla"
# bench_ros2.py's specs, for ROS 1 (noetic's types; rospy reads keep_all unbounded).
FORMULA_3_1 = bench_ros2.FORMULA_3_1.replace("time unit s\n", "ros noetic\ntime unit s\n", 1)
FLIPPING = bench_ros2.FLIPPING.replace("time unit s\n", "ros noetic\ntime unit s\n", 1)
THESIS_RATE = 18_391 / 100  # messages per second (table 4.1)


def _progress(step: int, total: int, text: str) -> None:
    bar = "#" * step + "." * (total - step)
    print(f"\r[{bar}] {step}/{total} {text:<60}", end="", file=sys.stderr, flush=True)


def _package(root: Path, name: str, text: str | None = None) -> Path:
    spec = root / f"{name}.rmv"
    if text is not None:
        spec.write_text(text, encoding="utf-8")
    result = check(str(spec))
    if result.errors:
        raise SystemExit(f"{name}: {[str(d) for d in result.errors]}")
    target("ros1").build(lower(result), root / name, {})
    return root / name


def _thesis_bag(path: Path, seconds: float) -> Path:
    """The braking recording's two topics, repeated at the thesis's rate."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Writer

    with AnyReader([CARLA / "recordings" / "braking.bag"]) as reader:
        connections = [c for c in reader.connections if c.topic.startswith("/carla/hero/")]
        messages = [(c.topic, data) for c, _, data in reader.messages(connections=connections)]
        with Writer(path) as writer:
            out = {
                c.topic: writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data,
                                               md5sum=c.digest, callerid="/carla_ros_bridge")
                for c in connections
            }  # fmt: skip
            step = int(1e9 / THESIS_RATE)
            for k in range(int(seconds * THESIS_RATE)):
                topic, data = messages[k % len(messages)]
                writer.write(out[topic], 1_700_000_000 * 10**9 + k * step, data)
    return path


def _load(home: Path, *args: str, timeout: float = 900) -> dict[str, Any]:
    logs = home / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    command = [rosenv1.python(), str(LOAD), str(logs), *args]
    run = rosenv1.run(command, home, timeout=timeout)
    if run.returncode != 0:
        raise SystemExit(
            f"ros1_load.py {args[0]} failed:\n{run.stdout[-2000:]}{run.stderr[-4000:]}"
        )
    result: dict[str, Any] = json.loads(run.stdout)
    bad = {k: v for k, v in result.get("counters", {}).items()
           if k.startswith(("lost", "late", "damaged"))}  # fmt: skip
    if bad:
        raise SystemExit(f"{args[0]}: the node lost messages: {bad}")
    return result


def _monitor(package: Path, *parameters: str) -> str:
    command = [rosenv1.python(), str(package / "scripts" / "monitor"),
               "_diagnostics_period:=0.05", *parameters]  # fmt: skip
    return json.dumps(command)


def _bare(mode: str) -> str:
    return json.dumps([rosenv1.python(), str(LOAD), "bare", mode])


def _soak(seconds: float, out: str | None) -> int:
    """tests/ros1/drive_soak.py for `seconds` on tests/ros1/soak.rmv's nodes: its
    figures (bench_ros2.judge) printed, and written to `out`."""
    sys.path.insert(0, str(ROOT / "tests"))
    from fleet_recordings import sent_bag

    rosenv1.python()
    with tempfile.TemporaryDirectory(prefix="rmv-bench-soak1-") as folder:
        root = Path(folder)
        os.environ["RMV_CACHE_DIR"] = str(root / "cache")
        spec = ROOT / "tests" / "ros1" / "soak.rmv"
        package = root / "soak1"
        target("ros1").build(lower(check(str(spec))), package, {})
        logs = root / "logs"
        logs.mkdir()
        print(f"soak on ROS 1: {seconds:g} s ...", file=sys.stderr, flush=True)
        command = [rosenv1.python(), str(ROOT / "tests" / "ros1" / "drive_soak.py"), str(logs),
                   str(package), str(seconds)]  # fmt: skip
        run = rosenv1.run(command, root / "home", timeout=seconds + 300)
        if run.returncode != 0:
            raise SystemExit(run.stderr[-4000:])
        seen = json.loads(run.stdout)
        recording = sent_bag(root / "sent", seen["sent"])
        return bench_ros2.report(bench_ros2.judge(seconds, seen, spec, recording), out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=5_000, help="messages for the rate")
    parser.add_argument("--seconds", type=float, default=100.0, help="of the thesis workload")
    parser.add_argument("--json", help="write the figures to this file")
    parser.add_argument("--soak", type=float, metavar="SECONDS", help="run only the soak")
    args = parser.parse_args(argv)
    if args.soak:
        return _soak(args.soak, args.json)

    total = 8
    _progress(0, total, "the ROS 1 venv, the packages, the bag")
    rosenv1.python()
    figures: dict[str, Any] = {"machine": {"cores": os.cpu_count()}}
    with tempfile.TemporaryDirectory(prefix="rmv-bench-ros1-") as folder:
        root = Path(folder)
        os.environ["RMV_CACHE_DIR"] = str(root / "cache")  # never the user's cache
        abs_package = _package(root, "bench_abs", FORMULA_3_1)
        flipping = _package(root, "bench_latency", FLIPPING)
        carla = root / "carla_abs.rmv"
        carla.write_text((CARLA / "abs.rmv").read_text().replace(
            'messages "msg"', f"messages {json.dumps(str(CARLA / 'msg'))}"))  # fmt: skip
        carla_package = _package(root, "carla_abs")
        bag = _thesis_bag(root / "thesis.bag", args.seconds)
        steps = [
            ("rate", "monitor", ("rate", _monitor(abs_package), str(args.count))),
            ("rate", "bare", ("rate", _bare("count"), str(args.count))),
            ("latency 100 Hz", "monitor", ("latency", _monitor(flipping), "100", "1000")),
            ("latency 100 Hz", "bare", ("latency", _bare("echo"), "100", "1000")),
            ("latency 1 kHz", "monitor", ("latency", _monitor(flipping), "1000", "5000")),
            ("latency 1 kHz", "bare", ("latency", _bare("echo"), "1000", "5000")),
            ("workload", "monitor", ("workload", _monitor(carla_package), str(bag))),
        ]
        for number, (what, reader, load) in enumerate(steps, start=1):
            _progress(number, total, f"{what}: {reader}")
            home = root / f"run{number}"
            figures.setdefault(what, {})[reader] = _load(home, *load)
        _progress(total, total, "done")
        print(file=sys.stderr)
    rate = figures["rate"]
    figures["rate"]["monitor / bare (per CPU second)"] = (
        rate["monitor"]["per_cpu_second"] / rate["bare"]["per_cpu_second"]
    )
    figures["rate"]["monitor / bare (wall)"] = (
        rate["monitor"]["per_second"] / rate["bare"]["per_second"]
    )
    figures["workload"]["messages per second"] = THESIS_RATE
    figures["workload"]["seconds"] = args.seconds
    text = json.dumps(figures, indent=2)
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
