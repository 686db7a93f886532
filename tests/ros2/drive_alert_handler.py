"""Kapacitor's `.exec` handler of a `publish` action, run as Kapacitor runs it: the
alert as JSON on standard input, the topic as an argument. Inside a private network
namespace (tests/test_ros2.py starts it through rosenv):

    python drive_alert_handler.py SCENARIO_JSON

The scenario names the handler, the topic and the runs: each an alert, the
handler's extra arguments, and whether a subscriber listens on the topic from that
run on (once one listens it stays). Prints JSON: each run's exit code and output, and the messages
the subscriber received, in order.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from typing import Any

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String


def run_handler(node: Any, scenario: dict[str, Any], alert: Any, args: list[str]) -> dict[str, Any]:
    """One handler process, the node spun while it runs (its subscriber must answer)."""
    command = [sys.executable, scenario["handler"], "--topic", scenario["topic"], *args]
    with tempfile.TemporaryFile() as out:  # read once it ended: a pipe could fill
        run = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=out,
                               stderr=subprocess.STDOUT)  # fmt: skip
        assert run.stdin is not None
        run.stdin.write(json.dumps(alert).encode())
        run.stdin.close()
        deadline = time.monotonic() + 60
        while run.poll() is None and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        run.wait(timeout=30)
        out.seek(0)
        output = out.read().decode(errors="replace")
    return {"code": run.returncode, "output": output}


def main() -> None:
    with open(sys.argv[1], encoding="utf-8") as file:
        scenario = json.load(file)
    rclpy.init()
    node = rclpy.create_node("alert_listener")
    received: list[str] = []
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)  # fmt: skip
    listening = False
    runs = []
    for step in scenario["runs"]:
        if step["listen"] and not listening:
            node.create_subscription(String, scenario["topic"], lambda m: received.append(m.data),
                                     qos)  # fmt: skip
            listening = True
        runs.append(run_handler(node, scenario, step["alert"], step.get("args", [])))
    end = time.monotonic() + 1.0  # the last messages may still be in flight
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.try_shutdown()
    print(json.dumps({"runs": runs, "received": received}))


if __name__ == "__main__":
    main()
