"""Kapacitor's `.exec` handler of a `publish` action, run as Kapacitor runs it: the
alert as JSON on standard input, the topic as an argument. Inside a private network
namespace (tests/test_ros2.py starts it through rosenv):

    python drive_alert_handler.py HANDLER ALERT_JSON_FILE TOPIC

Prints JSON: the messages a subscriber received on TOPIC, and the handler's exit
code and output.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String


def main() -> None:
    handler, alert_file, topic = sys.argv[1:4]
    rclpy.init()
    node = rclpy.create_node("alert_listener")
    received: list[str] = []
    qos = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(String, topic, lambda m: received.append(m.data), qos)
    with open(alert_file, "rb") as alert:
        run = subprocess.Popen(
            [sys.executable, handler, "--topic", topic], stdin=alert,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        )  # fmt: skip
        deadline = time.monotonic() + 30
        while (run.poll() is None or not received) and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        output = run.communicate(timeout=30)[0].decode(errors="replace")
    node.destroy_node()
    rclpy.try_shutdown()
    print(json.dumps({"received": received, "code": run.returncode, "output": output}))


if __name__ == "__main__":
    main()
