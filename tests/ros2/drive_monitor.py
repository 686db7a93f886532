"""Run inside a private network namespace (tests/test_ros2.py starts it): start the
generated monitor node as its own process, play TwistStamped messages to it, collect
what it publishes on /rmv/verdicts and /diagnostics, stop it, print them as JSON.

    python drive_monitor.py PACKAGE_DIR PACKAGE SCENARIO.json
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

DEADLINE = 30.0  # seconds for discovery and for each wait: discovery is racy on 2 cores


def wait_for(condition, node, what: str, seen: object = None) -> None:
    start = time.monotonic()
    while not condition():
        if time.monotonic() - start > DEADLINE:
            raise SystemExit(f"timed out waiting for {what} (seen: {seen})")
        rclpy.spin_once(node, timeout_sec=0.05)


def main(folder: str, package: str, scenario_path: str) -> int:
    with open(scenario_path, encoding="utf-8") as file:
        scenario = json.load(file)
    env = {**os.environ, "PYTHONPATH": folder + os.pathsep + os.environ.get("PYTHONPATH", "")}
    monitor = subprocess.Popen(
        [sys.executable, "-m", f"{package}.monitor_node"], env=env,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    rclpy.init()
    node = Node("player")
    verdicts: list[str] = []
    statuses: dict[str, dict[str, str]] = {}
    node.create_subscription(String, "/rmv/verdicts", lambda m: verdicts.append(m.data), 1000)

    def on_diagnostics(array: DiagnosticArray) -> None:
        for status in array.status:
            values = {v.key: v.value for v in status.values}
            statuses[status.name] = {"message": status.message, **values}

    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
    qos = QoSProfile(depth=1000, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.RELIABLE)  # fmt: skip
    publisher = node.create_publisher(TwistStamped, scenario["topic"], qos)
    try:
        wait_for(lambda: publisher.get_subscription_count() > 0, node, "the monitor")
        wait_for(lambda: node.count_publishers("/rmv/verdicts") > 0, node, "its verdicts")
        for stamp, speed in scenario["messages"]:
            message = TwistStamped()
            message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 10**9)
            message.twist.linear.x = float(speed)
            publisher.publish(message)
            rclpy.spin_once(node, timeout_sec=0.001)
        count = str(len(scenario["messages"]))
        wait_for(
            lambda: statuses.get("rmv_monitor: monitor", {}).get("messages") == count,
            node, "the monitor to count every message", statuses,
        )  # fmt: skip
        monitor.send_signal(signal.SIGINT)
        wait_for(lambda: monitor.poll() is not None, node, "the monitor to stop")
        end = time.monotonic()
        while time.monotonic() - end < 1.0:
            rclpy.spin_once(node, timeout_sec=0.05)
    except SystemExit:
        monitor.kill()
        print(monitor.communicate()[0], file=sys.stderr)
        raise
    finally:
        if monitor.poll() is None:
            monitor.kill()
        log = monitor.communicate()[0]
        node.destroy_node()
        rclpy.shutdown()
    print(json.dumps({"verdicts": verdicts, "diagnostics": statuses, "log": log,
                      "code": monitor.returncode}))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
