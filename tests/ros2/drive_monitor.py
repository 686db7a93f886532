"""Play a scenario to a generated monitor node and collect what it publishes. Runs
inside a private network namespace (tests/test_ros2.py starts it through rosenv):

    python drive_monitor.py SCENARIO.json

The scenario (JSON) names the monitor's command line, the topics to publish with their
types, and the steps: `["publish", topic, base64 CDR bytes]` sends recorded bytes as
they are (any type, decoded only by the node), `["clock", ns]` publishes /clock and
waits until the node's clock has reached it, `["settle"]` waits until the node has
counted every message sent so far, `["status", NAME, MESSAGE, SECONDS]` waits (at
most SECONDS) until the node's /diagnostics show status NAME with MESSAGE and notes
how long after the last publish it came, `["intruder", ros|dds|imposter, TOPIC]` starts an
intruder (tests/ros2/intruder.py) that stays until the end. `also` names more nodes
to start beside the monitor (its intrusion node). `late` names topics subscribed to only
after the steps, transient_local, as a subscriber that starts late would. Prints, as
JSON, the node's verdict segments, its last diagnostics, the status waits, what the
late subscribers got, its log and its exit code.
"""

from __future__ import annotations

import base64
import importlib
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from soaking import rss_kib  # this folder: the scripts run from it
from std_msgs.msg import String

INTRUDER = Path(__file__).resolve().parent / "intruder.py"
DEADLINE = 30.0  # seconds for discovery and for each wait: discovery is racy on 2 cores


def message_class(name: str) -> Any:
    package, _, type_name = name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), type_name)


class Player:
    def __init__(self, scenario: dict[str, Any]) -> None:
        self.node = Node("player")
        self.verdicts: list[str] = []
        self.statuses: dict[str, dict[str, str]] = {}
        self.clock_ns = -1
        self.last_publish = time.monotonic()
        self.waits: list[list[Any]] = []
        self.node.create_subscription(
            String, "/rmv/verdicts", lambda m: self.verdicts.append(m.data), 1000
        )
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.on_diagnostics, 10)
        # Transient local: a reader that matches late still gets every message.
        qos = QoSProfile(depth=10000, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)  # fmt: skip
        self.publishers = {
            topic: self.node.create_publisher(message_class(kind), topic, qos)
            for topic, kind in scenario["publishers"].items()
        }
        self.clock = self.node.create_publisher(Clock, "/clock", 10)
        self.intruders: list[subprocess.Popen[str]] = []
        self.monitor_pid = 0
        self.rss: list[int] = []  # the monitor's resident KiB at each "rss" step

    def intrude(self, kind: str, topic: str) -> None:
        intruder = subprocess.Popen(
            [sys.executable, str(INTRUDER), kind, topic],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        self.intruders.append(intruder)
        assert intruder.stdout is not None
        if intruder.stdout.readline().strip() != "ready":
            raise SystemExit(f"the {kind} intruder did not start")

    def on_diagnostics(self, array: DiagnosticArray) -> None:
        stamp = array.header.stamp.sec * 10**9 + array.header.stamp.nanosec
        for status in array.status:
            values = {v.key: v.value for v in status.values}
            self.statuses[status.name] = {"message": status.message, **values}
            if status.name == "rmv_monitor: monitor":
                self.clock_ns = stamp

    def wait_for(self, condition: Any, what: str, during: Any = None) -> None:
        start = time.monotonic()
        while not condition():
            if time.monotonic() - start > DEADLINE:
                raise SystemExit(f"timed out waiting for {what} (seen: {self.statuses})")
            if during is not None:
                during()
            rclpy.spin_once(self.node, timeout_sec=0.05)

    def set_clock(self, nanoseconds: int) -> None:
        message = Clock()
        message.clock.sec, message.clock.nanosec = divmod(nanoseconds, 10**9)
        self.wait_for(lambda: self.clock.get_subscription_count() > 0, "a /clock subscriber")
        self.wait_for(
            lambda: self.clock_ns >= nanoseconds, f"the node's clock to reach {nanoseconds}",
            during=lambda: self.clock.publish(message),
        )  # fmt: skip

    def wait_status(self, name: str, message: str, seconds: float) -> None:
        def shown() -> bool:
            return self.statuses.get(name, {}).get("message") == message

        deadline = time.monotonic() + seconds
        while not shown() and time.monotonic() < deadline:
            rclpy.spin_once(self.node, timeout_sec=0.01)
        waited = time.monotonic() - self.last_publish
        self.waits.append([name, message, round(waited, 3) if shown() else None])

    def subscribe_late(self, topics: list[str]) -> dict[str, list[str]]:
        """What subscribers that start now get of what was published before."""
        got: dict[str, list[str]] = {topic: [] for topic in topics}
        qos = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)  # fmt: skip
        for topic in topics:
            self.node.create_subscription(String, topic, lambda m, t=topic: got[t].append(m.data),
                                          qos)  # fmt: skip
        deadline = time.monotonic() + 5.0
        while not all(got.values()) and time.monotonic() < deadline:
            rclpy.spin_once(self.node, timeout_sec=0.05)
        return got

    def counted(self) -> int:
        """The messages the monitor has read or knows it lost."""
        counters = self.statuses.get("rmv_monitor: monitor", {})
        lost = sum(int(v) for k, v in counters.items() if k.startswith("lost messages: "))
        return int(counters.get("messages", "0")) + lost

    def play(self, steps: list[list[Any]], pace: float) -> int:
        published = 0
        for step in steps:
            if step[0] == "clock":
                self.set_clock(step[1])
                continue
            if step[0] == "status":
                self.wait_status(*step[1:])
                continue
            if step[0] == "intruder":
                self.intrude(*step[1:])
                continue
            if step[0] == "rss":
                self.rss.append(rss_kib(self.monitor_pid))
                continue
            if step[0] == "settle":  # until the monitor has counted all sent so far
                self.wait_for(lambda n=published: self.counted() >= n, "the monitor to settle")
                continue
            self.publishers[step[1]].publish(base64.b64decode(step[2]))
            self.last_publish = time.monotonic()
            published += 1
            deadline = time.monotonic() + pace
            rclpy.spin_once(self.node, timeout_sec=0)
            while time.monotonic() < deadline:
                rclpy.spin_once(self.node, timeout_sec=max(0.0, deadline - time.monotonic()))
        return published


def main(scenario_path: str) -> int:
    with open(scenario_path, encoding="utf-8") as file:
        scenario = json.load(file)
    # The node's log goes to a file: a pipe nobody reads while the node runs would
    # fill and stop the node mid-run.
    log_file = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (lives as long as the node)
    monitor = subprocess.Popen(scenario["monitor"], stdout=log_file, stderr=subprocess.STDOUT)
    others = [
        subprocess.Popen(command, stdout=log_file, stderr=subprocess.STDOUT)
        for command in scenario.get("also", [])
    ]
    rclpy.init()
    player = Player(scenario)
    player.monitor_pid = monitor.pid
    late: dict[str, list[str]] = {}
    try:
        for topic, publisher in player.publishers.items():
            player.wait_for(lambda p=publisher: p.get_subscription_count() > 0, f"{topic}'s reader")
        player.wait_for(lambda: player.node.count_publishers("/rmv/verdicts") > 0, "verdicts")
        count = player.play(scenario["steps"], scenario.get("pace", 0.001))
        player.wait_for(lambda: player.counted() == count, f"the monitor to count all {count}")
        late = player.subscribe_late(scenario.get("late", []))
        monitor.send_signal(signal.SIGINT)
        player.wait_for(lambda: monitor.poll() is not None, "the monitor to stop")
        end = time.monotonic()
        while time.monotonic() - end < 1.0:  # the last segments may still be in flight
            rclpy.spin_once(player.node, timeout_sec=0.05)
    finally:
        for intruder in player.intruders:
            if intruder.poll() is None:
                intruder.communicate("")  # stdin closed: it leaves cleanly
        for process in (monitor, *others):
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in (monitor, *others):
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        log_file.seek(0)
        log = log_file.read()
        print(f"the monitor's log:\n{log}", file=sys.stderr)
        player.node.destroy_node()
        rclpy.shutdown()
    print(json.dumps({"verdicts": player.verdicts, "diagnostics": player.statuses,
                      "waits": player.waits, "late": late, "log": log, "rss": player.rss,
                      "code": monitor.returncode,
                      "others": [p.returncode for p in others]}))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
