"""The load side of benchmarks/bench_ros2.py: runs inside a private network namespace
with the ROS 2 wheels (bench_ros2.py starts it through tests/ros2/rosenv.py).

    python ros2_load.py rate monitor|bare NODE_COMMAND_JSON COUNT
    python ros2_load.py latency monitor|bare NODE_COMMAND_JSON COUNT HZ
    python ros2_load.py workload monitor NODE_COMMAND_JSON SECONDS SCALE PAYLOADS_JSON
    python ros2_load.py workload collector NODE_COMMAND_JSON SECONDS SCALE PAYLOADS_JSON \
        INFLUXD_ROOT STATEMENTS_JSON

The node under test is a generated monitor or the bare subscriber (`bare` below,
started as `python ros2_load.py bare count|echo`), each its own process. Prints JSON.
"""

from __future__ import annotations

import base64
import itertools
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

TOPIC = "/bench/status"
DEADLINE = 60.0
QOS = QoSProfile(depth=1000, history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)


def braking(k: int) -> TwistStamped:
    """A braking cycle of 100 messages: cruise, hard brake, ABS, stop, accelerate."""
    message = TwistStamped()
    phase = k % 100
    speed, brake = 20.0, 0.0
    if 50 <= phase < 70:
        speed, brake = 20.0 - (phase - 50), 0.9
    elif 70 <= phase < 80:
        speed, brake = 2.0, 0.6
    elif 80 <= phase < 90:
        speed, brake = 0.0, 0.9
    elif phase >= 90:
        speed = 5.0
    message.twist.linear.x, message.twist.angular.z = speed, brake
    return message


def bare_subscriber(mode: str) -> None:
    """The ceiling: an rclpy subscriber that only counts (`count`, reported every
    50 ms on /bench/count) or answers each message at once (`echo`, on /bench/echo)."""
    rclpy.init()
    node = Node("bare_subscriber")
    count = [0]
    out = node.create_publisher(String, "/bench/echo" if mode == "echo" else "/bench/count", 1000)

    def on_message(message: TwistStamped) -> None:
        count[0] += 1
        if mode == "echo":
            out.publish(String(data=str(count[0])))

    node.create_subscription(TwistStamped, TOPIC, on_message, QOS)
    if mode == "count":
        node.create_timer(0.05, lambda: out.publish(String(data=str(count[0]))))
    stop = []
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    while not stop:
        rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.shutdown()


class Load:
    def __init__(self, command: list[str]) -> None:
        # The node's log goes to a file: a pipe nobody reads while the node runs
        # would fill and stop the node mid-run.
        self.log = tempfile.TemporaryFile()  # noqa: SIM115 (lives as long as the node)
        self.process = subprocess.Popen(command, stdout=self.log, stderr=subprocess.STDOUT)
        self.node = Node("load")
        self.counters: dict[str, str] = {}
        self.count = 0
        self.reports = 0
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.on_diagnostics, 10)
        self.node.create_subscription(String, "/bench/count", self.on_count, 10)

    def on_diagnostics(self, array: DiagnosticArray) -> None:
        for status in array.status:
            if status.name in ("rmv_monitor: monitor", "rmv_collector: influxdb"):
                self.reports += 1
                self.counters = {v.key: v.value for v in status.values}
                self.count = int(self.counters.get("messages", "0"))

    def on_count(self, message: String) -> None:
        self.count = int(message.data)

    def until(self, condition: Any, what: str, seen: Any = None, during: Any = None) -> None:
        start = time.monotonic()
        while not condition():
            if time.monotonic() - start > DEADLINE:
                found = f" (have {seen()})" if seen is not None else ""
                raise SystemExit(f"timed out waiting for {what}{found}: {self.stop()}")
            if during is not None:
                during()
                time.sleep(0.05)  # a retry every 50 ms, spinning in between
            rclpy.spin_once(self.node, timeout_sec=0.01)

    def usage(self) -> dict[str, float]:
        """CPU seconds and peak resident memory of the node under test."""
        with open(f"/proc/{self.process.pid}/stat", encoding="ascii") as file:
            fields = file.read().rsplit(")", 1)[1].split()
        ticks = os.sysconf("SC_CLK_TCK")
        with open(f"/proc/{self.process.pid}/status", encoding="ascii") as file:
            peak = next(int(line.split()[1]) for line in file if line.startswith("VmHWM"))
        return {"cpu_s": (int(fields[11]) + int(fields[12])) / ticks, "peak_rss_mb": peak / 1024}

    def stop(self) -> str:
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.node.destroy_node()
        self.log.seek(0)
        return self.log.read().decode(errors="replace")[-2000:]


def rate(command: list[str], count: int, bare: bool) -> dict[str, Any]:
    """`count` messages sent at once by a reliable writer that keeps them all, read by
    a keep-all reader: messages per second of wall time until all are read (bounded
    by the sender where it is the slower), and per CPU second of the reader (what
    the reader could take with a core of its own: its ceiling)."""
    load = Load(command)
    writer = QoSProfile(depth=count, history=HistoryPolicy.KEEP_LAST,
                        reliability=ReliabilityPolicy.RELIABLE)  # fmt: skip
    publisher = load.node.create_publisher(TwistStamped, TOPIC, writer)
    load.until(lambda: publisher.get_subscription_count() > 0, "the reader")
    messages = [braking(k) for k in range(count)]
    before = load.usage()
    start = time.monotonic()
    for message in messages:  # the writer keeps them all: the reader gets every one
        publisher.publish(message)
    load.until(lambda: load.count >= count, f"{count} messages to be read")
    elapsed = time.monotonic() - start
    usage = load.usage()
    cpu = usage["cpu_s"] - before["cpu_s"]
    counters = dict(load.counters)
    log = load.stop()
    return {"messages": load.count, "seconds": elapsed, "per_second": count / elapsed,
            "cpu_s": cpu, "per_cpu_second": count / cpu, "peak_rss_mb": usage["peak_rss_mb"],
            "counters": counters, "log": log}  # fmt: skip


def latency(command: list[str], count: int, hz: float, bare: bool) -> dict[str, Any]:
    """Receipt-to-verdict: messages at `hz` whose value flips a verdict each time; the
    time from sending message k+1 to receiving the segment it completes (or, for the
    bare subscriber, its echo of message k)."""
    load = Load(command)
    received: list[tuple[int, str]] = []
    for topic in ("/rmv/verdicts", "/bench/echo"):
        load.node.create_subscription(
            String, topic, lambda m: received.append((time.monotonic_ns(), m.data)), 1000
        )
    publisher = load.node.create_publisher(TwistStamped, TOPIC, QOS)
    load.until(lambda: publisher.get_subscription_count() > 0, "the reader")
    period = int(1e9 / hz)
    sent: list[int] = []
    next_at = time.monotonic_ns() + 200_000_000
    for k in range(count):
        message = TwistStamped()
        message.twist.linear.x = 7.0 if k % 2 else 1.0
        while (wait := next_at - time.monotonic_ns()) > 0:
            rclpy.spin_once(load.node, timeout_sec=wait / 1e9)
        sent.append(time.monotonic_ns())
        publisher.publish(message)
        next_at += period
    # The bare subscriber answers every message; the monitor completes a segment with
    # every message but the first (which opens one) and the last (its segment stays
    # open), so its answers line up with the messages from the end.
    wanted = count if bare else count - 2
    load.until(lambda: len(received) >= wanted, f"{wanted} answers", lambda: len(received))
    usage = load.usage()
    inside: dict[str, float] = {}
    if not bare:  # the node's own figures: from a message's arrival to its verdict
        reports = load.reports
        load.until(lambda: load.reports > reports, "the next diagnostics")
        inside = {f"node_{k}_ms": float(load.counters[f"verdict latency {k} (ms)"])
                  for k in ("p50", "p99")}  # fmt: skip
    log = load.stop()
    if not bare:
        verdicts = [json.loads(data)["verdict"] for _, data in received]
        if any(a == b for a, b in itertools.pairwise(verdicts)):
            raise SystemExit("the monitor's segments do not alternate: one was lost or merged")
    answered = sent[len(sent) - len(received) - (0 if bare else 1) :][: len(received)]
    delays = sorted((r - s) / 1e6 for (r, _), s in zip(received, answered, strict=True))
    return {"answers": len(received), "p50_ms": delays[len(delays) // 2],
            "p99_ms": delays[int(len(delays) * 0.99)], "max_ms": delays[-1], **inside, **usage,
            "log": log}  # fmt: skip


# Table 4.1 of the thesis: the CARLA bridge's topics and messages in 100 s.
THESIS_TOPICS = (
    ("/carla/actor_list", "carla_msgs/msg/CarlaActorList", 1),
    ("/carla/hero/gnss/front/fix", "sensor_msgs/msg/NavSatFix", 2006),
    ("/carla/hero/objects", "derived_object_msgs/msg/ObjectArray", 1820),
    ("/carla/hero/odometry", "nav_msgs/msg/Odometry", 1820),
    ("/carla/hero/vehicle_info", "carla_msgs/msg/CarlaEgoVehicleInfo", 1),
    ("/carla/hero/vehicle_status", "carla_msgs/msg/CarlaEgoVehicleStatus", 1820),
    ("/carla/marker", "visualization_msgs/msg/Marker", 3640),
    ("/carla/objects", "derived_object_msgs/msg/ObjectArray", 1818),
    ("/carla/status", "carla_msgs/msg/CarlaStatus", 1820),
    ("/carla/world_info", "carla_msgs/msg/CarlaWorldInfo", 1),
    ("/clock", "rosgraph_msgs/msg/Clock", 1821),
    ("/rosout", "rcl_interfaces/msg/Log", 5),
    # tf2_msgs has no wheel on PyPI: one transform a message instead of an array
    ("/tf", "geometry_msgs/msg/TransformStamped", 1818),
)


def lost(counters: dict[str, str]) -> int:
    """The messages the monitor counted as lost (gaps in sequence numbers)."""
    return sum(int(v) for k, v in counters.items() if k.startswith("lost messages: "))


def _stored(counters: dict[str, str]) -> int:
    """Points the collector wrote, or dropped and counted."""
    kept = ("points dropped", "points refused")
    return sum(int(v) for k, v in counters.items() if k == "points written" or k.startswith(kept))


def _influxd(root: str, statements: str) -> Any:
    """A real influxd in this namespace, its database made."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from influx.server import Influxd

    server = Influxd(Path(root), run_interval="1h")
    with open(statements, encoding="utf-8") as file:
        for statement in json.load(file):
            server.query(statement)
    return server


def _class(name: str) -> Any:
    import importlib

    package, _, type_name = name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), type_name)


def workload(
    command: list[str], seconds: float, scale: float, recorded: str, influx: Any = None
) -> dict[str, Any]:
    """The thesis's 13 topics at their rates times `scale` for `seconds`; the ego
    vehicle's status and objects are the braking recording's bytes, cycled. With
    `influx` (an Influxd) the node is the collector and the run waits until every
    point is written."""
    with open(recorded, encoding="utf-8") as file:
        payloads = {t: [base64.b64decode(d) for d in data] for t, data in json.load(file).items()}
    if influx is not None:
        command = [*command, "-p", f"influx_url:={influx.url}"]
    load = Load(command)
    publishers, schedule = {}, []
    for topic, kind, per_100s in THESIS_TOPICS:
        publishers[topic] = load.node.create_publisher(_class(kind), topic, 1000)
        count = max(1, round(per_100s * scale * seconds / 100))
        schedule.extend((k * seconds / count, topic) for k in range(count))
    schedule.sort()
    defaults = {t: _class(k)() for t, k, _ in THESIS_TOPICS}
    for topic in payloads:  # until the node reads each topic (matching is not symmetric)
        load.until(lambda t=topic: publishers[t].get_subscription_count() > 0, f"{topic}'s reader")
        base = load.count
        load.until(lambda b=base: load.count > b, f"a first message of {topic}",
                   during=lambda t=topic: publishers[t].publish(payloads[t][0]))  # fmt: skip
    warmed = load.count
    before = load.usage()
    sent, start = {t: 0 for t in publishers}, time.monotonic()
    for at, topic in schedule:
        while time.monotonic() - start < at:
            rclpy.spin_once(load.node, timeout_sec=max(0.0, at - (time.monotonic() - start)))
        data = payloads.get(topic)
        publishers[topic].publish(data[sent[topic] % len(data)] if data else defaults[topic])
        sent[topic] += 1
    wall = time.monotonic() - start
    read = warmed + sum(sent[t] for t in payloads)
    load.until(
        lambda: load.count + lost(load.counters) >= read,
        f"the monitor to account for {read}", lambda: load.counters,
    )  # fmt: skip
    if influx is not None:  # every point written, or dropped and counted
        load.until(lambda: _stored(load.counters) >= read - lost(load.counters),
                   "the collector to write every point", lambda: load.counters)  # fmt: skip
    after = load.usage()
    counters = dict(load.counters)
    log = load.stop()
    return {"messages_sent": sum(sent.values()), "messages_to_read": read,
            "messages_lost": lost(counters), "seconds": wall,
            "cpu_share": (after["cpu_s"] - before["cpu_s"]) / wall,
            "peak_rss_mb": after["peak_rss_mb"], "counters": counters, "log": log}  # fmt: skip


def main(argv: list[str]) -> int:
    if argv[0] == "bare":
        bare_subscriber(argv[1])
        return 0
    rclpy.init()
    kind, bare, command = argv[0], argv[1] == "bare", json.loads(argv[2])
    if kind == "rate":
        result = rate(command, int(argv[3]), bare)
    elif kind == "latency":
        result = latency(command, int(argv[3]), float(argv[4]), bare)
    elif bare:
        raise SystemExit("a workload runs a generated node")
    elif argv[1] == "collector":
        influx = _influxd(argv[6], argv[7])
        try:
            result = workload(command, float(argv[3]), float(argv[4]), argv[5], influx)
        finally:
            influx.stop()
    else:
        result = workload(command, float(argv[3]), float(argv[4]), argv[5])
    rclpy.shutdown()
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
