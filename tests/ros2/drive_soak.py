"""A soak: a generated monitor and intrusion node watched for SECONDS while allowed
nodes come and go around them and rogue publishers are injected now and then.
Runs inside a private network namespace (tests/test_ros2.py, benchmarks/bench_ros2.py
--soak):

    python drive_soak.py SCENARIO.json

The scenario names the two nodes' command lines, the watched topic, the topic the
intrusions are published on, `seconds`, `rate` (Hz of the twist messages this
player sends, stamped, their speeds from `seed`), `churn` (seconds between an
allowed node starting or stopping: a second /player publisher, or a /listener
subscriber, which the whitelist allows) and `rogue_every` (seconds between rogue
publishers, one starting at each multiple of it after half of it, each left for
4 s). Prints JSON: the messages sent (stamp, speed), the
node's verdict segments, every intrusion report with the node it names, each rogue's
report latency, both nodes' RSS samples and their exit codes.
"""

from __future__ import annotations

import json
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import rclpy
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from soaking import ROGUE_STAYS, START, rss_kib
from std_msgs.msg import String

INTRUDER = Path(__file__).resolve().parent / "intruder.py"


class Soak:
    def __init__(self, scenario: dict[str, Any]) -> None:
        self.scenario = scenario
        self.node = Node("player")
        qos = QoSProfile(depth=10000, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)  # fmt: skip
        self.twist = self.node.create_publisher(TwistStamped, scenario["topic"], qos)
        self.verdicts: list[str] = []
        self.reports: list[tuple[float, str]] = []
        self.node.create_subscription(
            String, "/rmv/verdicts", lambda m: self.verdicts.append(m.data), 10000
        )
        self.node.create_subscription(
            String, scenario["intrusions"],
            lambda m: self.reports.append((time.monotonic(), m.data)), 100,
        )  # fmt: skip
        self.sent: list[tuple[int, float]] = []
        self.speeds = random.Random(scenario.get("seed", 1))

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.005)

    def publish_next(self) -> None:
        """The next twist: cruising, now and then fast (a NotFastLong violation when
        it lasts) or stopped (a NeverStops violation)."""
        k = len(self.sent)
        stamp = START + k * int(1e9 / self.scenario["rate"])
        roll = self.speeds.random()
        previous = self.sent[-1][1] if self.sent else 20.0
        speed = previous if roll < 0.9 else self.speeds.choice([20.0, 30.0, 30.0, 0.0])
        message = TwistStamped()
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 10**9)
        message.twist.linear.x = speed
        self.twist.publish(message)
        self.sent.append((stamp, speed))


def start(kind: str, topic: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, str(INTRUDER), kind, topic],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert process.stdout is not None
    if process.stdout.readline().strip() != "ready":
        raise SystemExit(f"the {kind} node did not start")
    return process


def stop(process: subprocess.Popen[str]) -> None:
    if process.poll() is None:
        process.communicate("", timeout=30)  # stdin closed: it leaves cleanly


def run(soak: Soak, monitor: subprocess.Popen[bytes], watch: subprocess.Popen[bytes]) -> dict:
    scenario, topic = soak.scenario, soak.scenario["topic"]
    deadline = time.monotonic() + 60.0
    while soak.twist.get_subscription_count() == 0 or soak.node.count_publishers(
        "/rmv/verdicts"
    ) == 0:  # fmt: skip
        if time.monotonic() > deadline:
            raise SystemExit("the monitor never matched")
        soak.spin_for(0.05)
    started = time.monotonic()
    period = 1.0 / scenario["rate"]
    next_send = next_churn = started
    next_rogue = started + scenario["rogue_every"] / 2
    churning: list[subprocess.Popen[str]] = []
    rogue: tuple[subprocess.Popen[str], float, int] | None = None
    latencies: list[float | None] = []
    rss: list[tuple[float, int, int]] = []
    next_sample = started
    kinds = ["allowed-pub", "allowed-sub"]
    while time.monotonic() - started < scenario["seconds"]:
        now = time.monotonic()
        if now >= next_send:
            soak.publish_next()
            next_send += period
        if now >= next_churn and rogue is None:  # one allowed node starts or stops
            # (not while a rogue is timed: starting a process blocks this loop)
            if churning and (len(churning) >= 3 or random.random() < 0.5):
                stop(churning.pop(0))
            else:
                churning.append(start(kinds[len(soak.sent) % 2], topic))
            next_churn = time.monotonic() + scenario["churn"]
        if rogue is None and now >= next_rogue:
            # On a fixed cadence from the soak's start: a slow process start under load
            # must not push later rogues out of the soak.
            next_rogue += scenario["rogue_every"]
            rogue = (start("ros", topic), time.monotonic(), len(soak.reports))
        if rogue is not None:
            process, since, before = rogue
            named = [t for t, text in soak.reports[before:] if "/rogue" in text]
            if time.monotonic() - since >= ROGUE_STAYS:
                latencies.append(named[0] - since if named else None)
                stop(process)
                rogue = None
        if now >= next_sample:
            rss.append((round(now - started, 1), rss_kib(monitor.pid), rss_kib(watch.pid)))
            next_sample += 1.0
        rclpy.spin_once(soak.node, timeout_sec=min(period, 0.005))
    for process in churning:
        stop(process)
    if rogue is not None:
        stop(rogue[0])
    soak.spin_for(2.0)  # the last verdicts and reports
    return {"latencies": latencies, "rss": rss}


def main(scenario_path: str) -> int:
    with open(scenario_path, encoding="utf-8") as file:
        scenario = json.load(file)
    log_file = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (never a pipe nobody reads)
    monitor = subprocess.Popen(scenario["monitor"], stdout=log_file, stderr=subprocess.STDOUT)
    watch = subprocess.Popen(scenario["intrusion"], stdout=log_file, stderr=subprocess.STDOUT)
    rclpy.init()
    soak = Soak(scenario)
    try:
        found = run(soak, monitor, watch)
    finally:
        for process in (monitor, watch):
            process.send_signal(signal.SIGINT)
        for process in (monitor, watch):
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        soak.spin_for(0.5)
        log_file.seek(0)
        log = log_file.read()
        print(f"the nodes' log:\n{log[-20000:]}", file=sys.stderr)
        soak.node.destroy_node()
        rclpy.shutdown()
    print(json.dumps({
        "sent": soak.sent, "verdicts": soak.verdicts,
        "reports": [text for _, text in soak.reports], **found,
        "codes": [monitor.returncode, watch.returncode],
    }))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
