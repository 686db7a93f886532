"""Play messages to a generated collector node while a real influxd runs, stops and
starts again, all inside one private network namespace (tests/test_ros2.py starts
it through rosenv):

    python drive_collector.py SCENARIO.json

The scenario names the collector's command (without its InfluxDB parameters), the
statements that create the database, influxd's folder, the buffer bound and the
numbers of messages to send before and while influxd is down. Prints JSON: the
points stored (time, Speed), the collector's last diagnostics, its log and exit code.
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
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from influx.server import Influxd

DEADLINE = 30.0
START = 1_700_000_000 * 10**9
STEP = 50_000_000


class Player:
    def __init__(self) -> None:
        self.node = Node("player")
        self.status: dict[str, str] = {}
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.on_diagnostics, 10)
        qos = QoSProfile(depth=10000, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)  # fmt: skip
        self.publisher = self.node.create_publisher(TwistStamped, "/vehicle/twist", qos)

    def on_diagnostics(self, array: DiagnosticArray) -> None:
        for status in array.status:
            if status.name == "rmv_collector: influxdb":
                self.status = {v.key: v.value for v in status.values}
                self.status["_message"] = status.message

    def until(self, condition: Any, what: str, deadline: float = DEADLINE) -> None:
        deadline = time.monotonic() + deadline
        while not condition():
            if time.monotonic() > deadline:
                raise SystemExit(f"timed out waiting for {what}: {self.status}")
            rclpy.spin_once(self.node, timeout_sec=0.05)

    def send(self, first: int, count: int) -> None:
        for k in range(first, first + count):
            message = TwistStamped()
            stamp = START + k * STEP
            message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 10**9)
            message.twist.linear.x = float(k)
            self.publisher.publish(message)
            rclpy.spin_once(self.node, timeout_sec=0)


def stored(influxd: Influxd, database: str) -> list[list[Any]]:
    return influxd.points('SELECT "Speed" FROM "collected"', database)


def main() -> None:
    scenario = json.loads(Path(sys.argv[1]).read_text())
    influxd = Influxd(Path(scenario["influx_root"]), run_interval="1h")
    for statement in scenario["statements"]:
        influxd.query(statement)
    database = scenario["database"]
    log = tempfile.TemporaryFile()  # noqa: SIM115 (lives as long as the node)
    command = [*scenario["command"], "-p", f"influx_url:={influxd.url}"]
    node = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
    rclpy.init()
    player = Player()
    result: dict[str, Any] = {}
    try:
        player.until(lambda: player.publisher.get_subscription_count() > 0, "the collector")
        before, during = scenario["before"], scenario["during"]
        states = scenario.get("states", 0)
        player.send(0, before)
        player.until(lambda: len(stored(influxd, database)) == before, "the first points")
        # the states too (the runtime decides some on its timer), before influxd stops
        player.until(lambda: player.status.get("points written") == str(before + states),
                     "the first states")  # fmt: skip
        influxd.stop()
        stopped = time.monotonic()
        player.send(before, during)
        total = before + during
        player.until(lambda: player.status.get("messages") == str(total), "every message")
        # `down_for`: influxd stays away that long at least (the collector retries,
        # its back-off growing to 30 s)
        player.until(lambda: time.monotonic() - stopped >= scenario.get("down_for", 0),
                     "the outage's end", deadline=scenario.get("down_for", 0) + 60)  # fmt: skip
        result["while_down"] = dict(player.status)
        result["down_s"] = round(time.monotonic() - stopped, 1)
        influxd.start()
        kept = total - int(player.status.get("points dropped: buffer full", "0"))
        player.until(lambda: len(stored(influxd, database)) == kept, f"{kept} points")
        player.until(lambda: player.status.get("points written") == str(kept + states),
                     "the counters")  # fmt: skip
        result["stored"] = stored(influxd, database)
        result["states"] = influxd.points(
            'SELECT "state", "transducer" FROM "collected_states"', database
        )
        result["status"] = dict(player.status)
    finally:
        node.send_signal(signal.SIGINT)
        try:
            result["code"] = node.wait(timeout=20)
        except subprocess.TimeoutExpired:
            node.kill()
            result["code"] = node.wait()
        log.seek(0)
        result["log"] = log.read().decode(errors="replace")[-3000:]
        player.node.destroy_node()
        rclpy.try_shutdown()
        influxd.stop()
    print(json.dumps(result))


if __name__ == "__main__":
    main()
