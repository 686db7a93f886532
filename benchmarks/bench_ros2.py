"""The generated ROS 2 monitor node against a bare rclpy subscriber, on ROS 2 from
PyPI, every process inside a private network namespace holding only loopback.

Builds, with colcon, the packages `rmv build --target ros2` writes for three specs
(formula 3.1 on one topic; a property whose verdict flips with every message; the
CARLA example) beside the CARLA message packages, then measures, each node its own
process and the load in another (benchmarks/ros2_load.py):

- rate:     5,000 messages sent at once to formula 3.1 (its transducer, sampled
            at 10 Hz as abs.rmv does; receipt time), beside the bare subscriber that
            only counts: messages per second of wall time (here the Python sender is
            the slower side) and per CPU second of the reader process, its ceiling
            with a core of its own (goal: the monitor >= 50% of the bare one);
- latency:  at 1 kHz, from sending a message to receiving the verdict segment it
            completes on /rmv/verdicts, beside the bare subscriber's echo (goal:
            p99 < 1 ms). Formula 3.1 looks 10 s ahead, so its verdicts wait 10 s by
            definition: the latency spec's property is about the present;
- workload: the thesis's (table 4.1: 13 topics, 18,391 messages in 100 s) with
            examples/carla/abs.rmv, and the same at 10x the rate: CPU share (of one
            core) and peak memory of the node, and the messages its readers (depth
            10, as abs.rmv says) lost, each counted by the node;
- collector: the kapacitor target's collector of abs.rmv on the same workload
            (1x), writing to a real influxd in the same namespace: CPU, memory, and
            the delay from a message's arrival to InfluxDB's answer, p50 and p99.

Before a figure is printed, every message must have been read (the node's counters:
none lost, none late) and every verdict answered.

    python benchmarks/bench_ros2.py [--seconds 100] [--count 5000]
    python benchmarks/bench_ros2.py --json benchmarks/results/ros2.json

`--soak SECONDS` runs only the soak instead (tests/ros2/drive_soak.py on
tests/ros2/soak.rmv's nodes; the test suite runs 60 s of it): allowed nodes starting
and stopping every 2 s, a rogue publisher every 10 s; false alarms, each rogue's
report latency, the nodes' memory over time, and the verdicts against a replay of
what was sent.

    python benchmarks/bench_ros2.py --soak 600 --json benchmarks/results/soak.json
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "ros2"))
import rosenv  # noqa: E402

from rmvdsl.check import check  # noqa: E402
from rmvdsl.dialects.influxql import split as split_statements  # noqa: E402
from rmvdsl.ir import lower  # noqa: E402
from rmvdsl.targets import kapacitor, ros2  # noqa: E402

LOAD = Path(__file__).resolve().parent / "ros2_load.py"
CARLA = ROOT / "examples" / "carla"
FORMULA_3_1 = """system bench_abs "formula 3.1 on one topic"
time unit s
topic status: geometry_msgs/msg/TwistStamped = "/bench/status" qos {
    depth = 1000
    history = keep_all
}
var Speed = status.twist.linear.x
var Brake = status.twist.angular.z
event HardBrake when Brake > 0.8 and Speed > 0.1
event AbsEngaged when Brake > 0.4 and Brake <= 0.8 and Speed > 1
event VehicleStopped when Speed < 0.1
event Accelerating when Brake < 0.1 and Speed > 0.1
transducer Braking {
    states Cruising, HardBraking, AntiLockBrake, Stopped
    initial Cruising
    Cruising -> HardBraking on HardBrake
    HardBraking -> AntiLockBrake on AbsEngaged
    AntiLockBrake -> HardBraking on HardBrake
    HardBraking -> Stopped on VehicleStopped
    AntiLockBrake -> Stopped on VehicleStopped
    Stopped -> Cruising on Accelerating
}
property ABSCheck: (HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped) and duration[10s](HardBraking) < 4s {
    rate = 10Hz
}
"""  # noqa: E501
FLIPPING = """system bench_latency "a verdict segment per message"
time unit s
topic status: geometry_msgs/msg/TwistStamped = "/bench/status" qos {
    depth = 1000
    history = keep_all
}
var Speed = status.twist.linear.x
event High when Speed > 5
property Low: not High
"""


def _progress(step: int, total: int, text: str) -> None:
    bar = "#" * step + "." * (total - step)
    print(f"\r[{bar}] {step}/{total} {text:<60}", end="", file=sys.stderr, flush=True)


def _workspace(root: Path) -> Path:
    src = root / "src"
    specs = {"bench_abs": FORMULA_3_1, "bench_latency": FLIPPING}
    for name, text in specs.items():
        path = root / f"{name}.rmv"
        path.write_text(text, encoding="utf-8")
        result = check(str(path))
        if result.errors:
            raise SystemExit(f"{name}: {[str(d) for d in result.errors]}")
        ros2.build(lower(result), src / name)
    carla = lower(check(str(CARLA / "abs.rmv")))
    ros2.build(carla, src / "carla_abs")
    collector = kapacitor.collector_files(kapacitor.plan(carla, root / "handlers"))
    ros2.write(collector, src / "carla_abs_kapacitor")
    rosenv.message_package(src, CARLA / "msg" / "carla_msgs", ["std_msgs", "geometry_msgs"])
    rosenv.message_package(
        src, CARLA / "msg" / "derived_object_msgs", ["std_msgs", "geometry_msgs", "shape_msgs"]
    )
    built = rosenv.colcon_build(root)
    if built.returncode != 0:
        raise SystemExit(f"colcon build failed:\n{(built.stdout + built.stderr)[-4000:]}")
    return root


def _soak(seconds: float, out: str | None) -> int:
    """The soak for `seconds`: its figures printed, and written to `out`."""
    rosenv.python()
    with tempfile.TemporaryDirectory(prefix="rmv-bench-soak-") as folder:
        root = Path(folder)
        os.environ["RMV_CACHE_DIR"] = str(root / "cache")
        spec = root / "soak.rmv"
        spec.write_text((ROOT / "tests" / "ros2" / "soak.rmv").read_text(encoding="utf-8"))
        ros2.build(lower(check(str(spec))), root / "src" / "soak")
        built = rosenv.colcon_build(root)
        if built.returncode != 0:
            raise SystemExit(f"colcon build failed:\n{(built.stdout + built.stderr)[-4000:]}")
        print(f"soak: {seconds:g} s ...", file=sys.stderr, flush=True)
        run = rosenv.soak(root, root, seconds, rosenv.DOMAIN + 21)
        if run.returncode != 0:
            raise SystemExit(run.stderr[-4000:])
        seen = json.loads(run.stdout)
        recording = root / "sent"
        _write_twists(recording, seen["sent"])
        return report(judge(seconds, seen, spec, recording), out)


def judge(seconds: float, seen: dict[str, Any], spec: Path, recording: Path) -> dict[str, Any]:
    """The figures of a soak (tests/ros2/drive_soak.py's or tests/ros1/drive_soak.py's
    JSON), its verdicts compared with `rmv replay SPEC RECORDING` of what it sent."""
    import subprocess

    replay = subprocess.run(
        [sys.executable, "-m", "rmvdsl.cli", "replay", str(spec), str(recording), "--format",
         "jsonl"], capture_output=True, text=True,
    )  # fmt: skip
    from_replay = [json.loads(line) for line in replay.stdout.splitlines()
                   if '"kind": "verdict"' in line]  # fmt: skip
    from_node = [json.loads(v) for v in seen["verdicts"]]
    false_alarms = [text for text in seen["reports"] if "/rogue" not in text]
    latencies = seen["latencies"]
    rss = seen["rss"]
    warm = rss[len(rss) // 4]
    growth = [rss[-1][i] / warm[i] - 1 for i in (1, 2)]
    return {
        "seconds": seconds, "messages_sent": len(seen["sent"]),
        "verdict_segments": len(from_node),
        "verdicts_equal_replay": _by_property(from_node) == _by_property(from_replay),
        "false_alarms": len(false_alarms), "false_alarm_reports": false_alarms[:10],
        "rogues": len(latencies),
        "rogue_latency_max_s": max((x for x in latencies if x is not None), default=None),
        "rogue_latency_median_s": statistics.median(x for x in latencies if x is not None)
        if any(x is not None for x in latencies) else None,
        "rogues_unreported": sum(1 for x in latencies if x is None),
        "rss_kib_after_warmup": {"monitor": [warm[1], rss[-1][1]],
                                 "intrusion": [warm[2], rss[-1][2]]},
        "rss_growth": {"monitor": round(growth[0], 4), "intrusion": round(growth[1], 4)},
        "exit_codes": seen["codes"],
    }  # fmt: skip


def report(figures: dict[str, Any], out: str | None) -> int:
    """Print the soak's figures, write them to `out`; 1 when the soak failed."""
    print(json.dumps(figures, indent=2))
    if out:
        Path(out).write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")
    good = (figures["verdicts_equal_replay"] and not figures["false_alarms"]
            and figures["rogues_unreported"] == 0)  # fmt: skip
    return 0 if good else 1


def _by_property(verdicts: list[dict]) -> dict[str, list[dict]]:
    found: dict[str, list[dict]] = {}
    for verdict in verdicts:
        found.setdefault(verdict["property"], []).append(verdict)
    return found


def _write_twists(path: Path, sent: list[list[float]]) -> None:
    """What the soak sent, as a rosbag2 (.mcap) logged at the stamps."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    name = "geometry_msgs/msg/TwistStamped"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/vehicle/twist", name, typestore=store)
        for stamp, speed in sent:
            stamp = int(stamp)
            header = types["std_msgs/msg/Header"](
                stamp=types["builtin_interfaces/msg/Time"](*divmod(stamp, 10**9)), frame_id=""
            )
            vector = types["geometry_msgs/msg/Vector3"]
            twist = types["geometry_msgs/msg/Twist"](vector(speed, 0.0, 0.0),
                                                     vector(0.0, 0.0, 0.0))  # fmt: skip
            message = types[name](header=header, twist=twist)
            writer.write(connection, stamp, store.serialize_cdr(message, name))


def _payloads(path: Path) -> None:
    """The braking recording's bytes of the two topics abs.rmv reads."""
    from rosbags.highlevel import AnyReader

    found: dict[str, list[str]] = {}
    with AnyReader([CARLA / "recordings" / "braking_mcap"]) as reader:
        for connection, _, data in reader.messages():
            found.setdefault(connection.topic, []).append(base64.b64encode(data).decode())
    path.write_text(json.dumps(found), encoding="utf-8")


def _load(workspace: Path, domain: int, *args: str, timeout: float = 600) -> dict[str, Any]:
    run = rosenv.run([rosenv.python(), str(LOAD), *args], domain, workspace, timeout=timeout)
    if run.returncode != 0:
        output = run.stdout[-2000:] + run.stderr[-4000:]
        raise SystemExit(f"ros2_load.py {args[0]} failed:\n{output}")
    return json.loads(run.stdout)


def _monitor(workspace: Path, package: str, *parameters: str) -> str:
    script = workspace / "install" / package / "lib" / package / "monitor"
    command = [str(script), "--ros-args", "-p", "diagnostics_period:=0.05"]
    for parameter in parameters:
        command += ["-p", parameter]
    return json.dumps(command)


def _bare(mode: str) -> str:
    return json.dumps([rosenv.python(), str(LOAD), "bare", mode])


def _all_read(result: dict[str, Any], what: str, lost_allowed: bool = False) -> None:
    """Every message read, or (where loss is a figure) read or counted lost."""
    counters = result.get("counters", {})
    prefixes = ("late", "damaged") if lost_allowed else ("lost", "late", "damaged")
    bad = {k: v for k, v in counters.items() if k.startswith(prefixes)}
    if bad:
        raise SystemExit(f"{what}: the node lost messages: {bad}")


def _collector(
    workspace: Path, domain: int, folder: Path, payloads: Path, seconds: float
) -> dict[str, Any]:
    """The kapacitor target's collector on the thesis's workload, writing to a real
    influxd started inside the same namespace (its schema from influxdb.iql)."""
    carla = lower(check(str(CARLA / "abs.rmv")))
    texts, _ = kapacitor.files(carla, folder / "kapacitor")
    statements = [s for s in split_statements(texts["influxdb.iql"])
                  if not s.startswith("CREATE CONTINUOUS QUERY")]  # fmt: skip
    schema = folder / "schema.json"
    schema.write_text(json.dumps(statements), encoding="utf-8")
    (folder / "influxd").mkdir()
    script = workspace / "install" / "carla_abs_collector" / "lib" / "carla_abs_collector"
    command = json.dumps(
        [str(script / "collector"), "--ros-args", "-p", "diagnostics_period:=0.05"]
    )
    stored = _load(workspace, domain, "workload", "collector", command, str(seconds), "1",
                   str(payloads), str(folder / "influxd"), str(schema),
                   timeout=seconds + 300)  # fmt: skip
    _all_read(stored, "collector", lost_allowed=True)
    return stored


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=5_000, help="messages for the rate")
    parser.add_argument("--latency-count", type=int, default=5_000)
    parser.add_argument("--hz", type=float, default=1000.0)
    parser.add_argument("--seconds", type=float, default=100.0, help="of the 1x workload")
    parser.add_argument("--seconds-10x", type=float, default=30.0, help="of the 10x workload")
    parser.add_argument("--json", help="write the figures to this file")
    parser.add_argument("--soak", type=float, metavar="SECONDS", help="run only the soak")
    args = parser.parse_args(argv)
    if args.soak:
        return _soak(args.soak, args.json)

    total = 8
    _progress(0, total, "ROS 2 wheels and colcon build")
    rosenv.python()
    with tempfile.TemporaryDirectory(prefix="rmv-bench-ros2-") as folder:
        os.environ["RMV_CACHE_DIR"] = str(Path(folder) / "cache")  # never the user's cache
        workspace = _workspace(Path(folder))
        payloads = Path(folder) / "payloads.json"
        _payloads(payloads)
        domain = rosenv.DOMAIN + 20
        count = str(args.count)
        _progress(1, total, "rate: bare subscriber")
        bare_rate = _load(workspace, domain, "rate", "bare", _bare("count"), count)
        _progress(2, total, "rate: monitor (formula 3.1)")
        rate = _load(workspace, domain, "rate", "monitor", _monitor(workspace, "bench_abs"), count)
        _all_read(rate, "rate")
        n, hz = str(args.latency_count), str(args.hz)
        _progress(3, total, "latency: bare echo")
        bare_latency = _load(workspace, domain, "latency", "bare", _bare("echo"), n, hz)
        _progress(4, total, "latency: monitor")
        latency = _load(
            workspace, domain, "latency", "monitor", _monitor(workspace, "bench_latency"), n, hz
        )
        _progress(5, total, f"workload 1x ({args.seconds:g} s)")
        carla = _monitor(workspace, "carla_abs")
        one = _load(workspace, domain, "workload", "monitor", carla, str(args.seconds), "1",
                    str(payloads), timeout=args.seconds + 300)  # fmt: skip
        _all_read(one, "workload 1x", lost_allowed=True)
        _progress(6, total, f"workload 10x ({args.seconds_10x:g} s)")
        ten = _load(workspace, domain, "workload", "monitor", carla, str(args.seconds_10x),
                    "10", str(payloads), timeout=args.seconds_10x + 300)  # fmt: skip
        _all_read(ten, "workload 10x", lost_allowed=True)
        _progress(7, total, f"collector, workload 1x ({args.seconds:g} s)")
        stored = _collector(workspace, domain, Path(folder), payloads, args.seconds)
        _progress(8, total, "done")
        print(file=sys.stderr)

    if rate["messages"] != args.count or bare_rate["messages"] != args.count:
        raise SystemExit("the rate runs did not read every message")
    share = rate["per_cpu_second"] / bare_rate["per_cpu_second"]
    print(
        f"rate (formula 3.1 at 10 Hz, {args.count:,} messages at once), msg/s of wall time "
        "and per CPU second of the reader:"
    )
    for name, result in (("bare rclpy subscriber", bare_rate), ("monitor node", rate)):
        print(f"  {name:<21} {result['per_second']:8,.0f} {result['per_cpu_second']:8,.0f}")
    print(f"  monitor / bare per CPU second: {share:.0%} (goal >= 50%)")
    print(f"latency at {args.hz:g} Hz ({args.latency_count:,} messages), p50 / p99 / max ms:")
    for name, result in (("bare echo", bare_latency), ("monitor verdict", latency)):
        print(f"  {name:<21} {result['p50_ms']:.3f} / {result['p99_ms']:.3f} / "
              f"{result['max_ms']:.3f}")  # fmt: skip
    print(f"  inside the node, arrival to verdict published: {latency['node_p50_ms']:.3f} / "
          f"{latency['node_p99_ms']:.3f} ms p50 / p99 (goal p99 < 1 ms)")  # fmt: skip
    print("thesis workload (13 topics, table 4.1), the node reading 2 of them:")
    for name, result in (("1x", one), ("10x", ten)):
        print(
            f"  {name:>3}: {result['messages_sent']:,} messages in {result['seconds']:.0f} s, "
            f"CPU {result['cpu_share']:.1%} of a core, peak RSS {result['peak_rss_mb']:.0f} MB, "
            f"lost {result['messages_lost']} of {result['messages_to_read']:,} (counted)"
        )
    counters = stored["counters"]
    print(
        f"collector, thesis workload 1x: {stored['messages_to_read']:,} messages read, "
        f"{counters.get('points written', 0)} points written, CPU {stored['cpu_share']:.1%} of "
        f"a core, peak RSS {stored['peak_rss_mb']:.0f} MB, storage delay p50 / p99 "
        f"{counters.get('storage delay p50 (ms)')} / {counters.get('storage delay p99 (ms)')} ms"
    )
    figures = {
        "rate": {"bare": bare_rate, "monitor": rate, "share": share},
        "collector": stored,
        "latency": {"bare": bare_latency, "monitor": latency},
        "workload": {"1x": one, "10x": ten},
    }
    if args.json:
        for group in figures.values():
            for result in group.values() if isinstance(group, dict) else ():
                if isinstance(result, dict):
                    result.pop("log", None)
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
