"""Start a generated intrusion node, then an allowed publisher, a rogue ROS node and
a bare DDS writer, and time how long each intrusion takes to be reported on the
spec's topic. Runs inside a private network namespace (tests/test_ros2.py):

    python drive_intrusion.py SCENARIO.json

The scenario names the intrusion node's command line, the watched topic, the topic
the intrusions are published on and how long to watch the allowed node alone.
Prints JSON: every report with its time, the latency of each intruder, the node's
last diagnostics and its log.
"""

from __future__ import annotations

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
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from std_msgs.msg import String

DEADLINE = 30.0
INTRUDER = Path(__file__).resolve().parent / "intruder.py"
STATUS = "rmv_intrusion: intrusions"


class Watcher:
    def __init__(self, scenario: dict[str, Any]) -> None:
        self.node = Node("player")
        self.node.create_publisher(TwistStamped, scenario["topic"], 10)  # allowed
        self.reports: list[tuple[float, str]] = []
        self.status: dict[str, Any] = {}
        self.node.create_subscription(
            String, scenario["intrusions"],
            lambda m: self.reports.append((time.monotonic(), m.data)), 100,
        )  # fmt: skip
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.on_diagnostics, 10)

    def on_diagnostics(self, array: DiagnosticArray) -> None:
        for status in array.status:
            if status.name == STATUS:
                values = {v.key: v.value for v in status.values}
                self.status = {"message": status.message, "values": values}

    def spin_until(self, condition: Any, what: str, deadline: float = DEADLINE) -> None:
        start = time.monotonic()
        while not condition():
            if time.monotonic() - start > deadline:
                raise SystemExit(f"timed out waiting for {what}; reports: {self.reports}")
            rclpy.spin_once(self.node, timeout_sec=0.02)

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.02)

    def intrude(self, kind: str, topic: str, name: str) -> tuple[subprocess.Popen[str], float]:
        """Start an intruder; the seconds from its writer's creation to its report."""
        intruder = subprocess.Popen(
            [sys.executable, str(INTRUDER), kind, topic],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        assert intruder.stdout is not None
        if intruder.stdout.readline().strip() != "ready":
            raise SystemExit(f"the {kind} intruder did not start")
        ready = time.monotonic()
        self.spin_until(lambda: any(name in text for _, text in self.reports), f"{name}'s report")
        reported = next(t for t, text in self.reports if name in text)
        return intruder, reported - ready


def main(scenario_path: str) -> int:
    with open(scenario_path, encoding="utf-8") as file:
        scenario = json.load(file)
    log_file = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (never a pipe nobody reads)
    node = subprocess.Popen(scenario["intrusion_node"], stdout=log_file, stderr=subprocess.STDOUT)
    rclpy.init()
    watcher = Watcher(scenario)
    intruders = []
    latencies = {}
    try:
        watcher.spin_until(lambda: bool(watcher.status), "the intrusion node's diagnostics")
        watcher.spin_for(scenario["allowed_for"])
        allowed_reports = list(watcher.reports)
        for kind, name in (("ros", "/rogue"), ("dds", "_CREATED_BY_BARE_DDS_APP_")):
            intruder, latency = watcher.intrude(kind, scenario["topic"], name)
            intruders.append(intruder)
            latencies[name] = latency
        watcher.spin_until(lambda: len(watcher.status["values"]) == 2, "both in diagnostics")
        while_present = dict(watcher.status)
        for intruder in intruders:
            intruder.communicate("")  # stdin closed: it leaves cleanly
        watcher.spin_until(lambda: not watcher.status["values"], "the intrusions to end")
    finally:
        for intruder in intruders:
            if intruder.poll() is None:
                intruder.kill()
        node.send_signal(signal.SIGINT)
        try:
            node.wait(timeout=10)
        except subprocess.TimeoutExpired:
            node.kill()
            node.wait()
        log_file.seek(0)
        log = log_file.read()
        print(f"the intrusion node's log:\n{log}", file=sys.stderr)
        watcher.node.destroy_node()
        rclpy.shutdown()
    print(json.dumps({
        "allowed_reports": [text for _, text in allowed_reports],
        "reports": [text for _, text in watcher.reports], "latencies": latencies,
        "while_present": while_present, "after": watcher.status, "log": log,
        "code": node.returncode,
    }))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
