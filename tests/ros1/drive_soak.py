"""The ROS 1 soak, inside the namespace: roscore, the generated monitor and
intrusion nodes, then for SECONDS: twist messages at 20 Hz from /player (stamped,
their speeds from a seeded generator as tests/ros2/drive_soak.py's), an allowed
node starting or stopping every 2 s (an /allowed_N publisher that sends nothing,
or a /listener_N subscriber), and a /rogueNN publisher every 10 s from 5 s, each for
4 s after the master lists it. Prints one JSON object: the messages sent (stamp,
speed), the verdict segments, every intrusion report, each rogue's report latency
(from when the master lists it), both nodes' RSS once a second and their exit
codes.

usage: drive_soak.py LOGS PACKAGE_DIR SECONDS
"""

from __future__ import annotations

import json
import random
import sys
import threading
import time
from pathlib import Path

import core
import rospy
from geometry_msgs.msg import TwistStamped
from std_msgs.msg import String

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "ros2"))
from soaking import ROGUE_STAYS, START, rss_kib  # noqa: E402

TOPIC = "/vehicle/twist"
RATE, CHURN, ROGUE_EVERY = 20, 2.0, 10.0


class Soak:
    def __init__(self, logs: Path) -> None:
        self.logs = logs
        self.lock = threading.Lock()
        self.verdicts: list[str] = []
        self.reports: list[tuple[float, str]] = []
        self.sent: list[tuple[int, float]] = []
        self.speeds = random.Random(5)
        self.twist = rospy.Publisher(TOPIC, TwistStamped, queue_size=1000)
        rospy.Subscriber("/rmv/verdicts", String, self.on_verdict, queue_size=None)
        rospy.Subscriber("/rmv/intrusion", String, self.on_report, queue_size=None)
        self.started = 0

    def on_verdict(self, message: String) -> None:
        with self.lock:
            self.verdicts.append(message.data)

    def on_report(self, message: String) -> None:
        with self.lock:
            self.reports.append((time.monotonic(), message.data))

    def publish_next(self) -> None:
        """As the ROS 2 soak: cruising, now and then fast or stopped."""
        k = len(self.sent)
        stamp = START + k * (10**9 // RATE)
        previous = self.sent[-1][1] if self.sent else 20.0
        roll = self.speeds.random()
        speed = previous if roll < 0.9 else self.speeds.choice([20.0, 30.0, 30.0, 0.0])
        message = TwistStamped()
        message.header.stamp = rospy.Time(*divmod(stamp, 10**9))
        message.twist.linear.x = speed
        self.twist.publish(message)
        self.sent.append((stamp, speed))

    def peer(self, name: str, role: str) -> object:
        self.started += 1
        log = self.logs / f"{name.strip('/')}-{self.started}.log"
        return core.start([core.python(), str(HERE / "peer.py"), name, role, TOPIC], log)


def soak(soak: Soak, seconds: float, nodes: list) -> dict:
    started = time.monotonic()
    next_send = next_churn = started
    next_rogue = started + ROGUE_EVERY / 2
    next_sample = started
    churning: list = []
    rogue = None  # (process, when the master listed it or None, reports before, name)
    latencies: list[float | None] = []
    rss: list[tuple[float, int, int]] = []
    while time.monotonic() - started < seconds:
        now = time.monotonic()
        if now >= next_send:
            soak.publish_next()
            next_send += 1.0 / RATE
        if now >= next_churn:
            if churning and (len(churning) >= 3 or random.random() < 0.5):
                core.stop(churning.pop(0))
            elif len(soak.sent) % 2:
                churning.append(soak.peer(f"/allowed_{soak.started}", "quiet"))
            else:
                churning.append(soak.peer(f"/listener_{soak.started}", "subscriber"))
            next_churn = now + CHURN
        if rogue is None and now >= next_rogue:
            next_rogue += ROGUE_EVERY  # a fixed cadence, as tests/ros2/drive_soak.py's
            # Each rogue a node of its own name: one named as the last, 6 s after it
            # stopped, may find the master still listing the last (it replaces that
            # registration, and the graph does not change).
            name = f"/rogue{len(latencies) + 1:02d}"
            rogue = (soak.peer(name, "quiet"), None, len(soak.reports), name)
        if rogue is not None:
            process, listed, before, name = rogue
            if listed is None and core.publishes(name, TOPIC):
                rogue = (process, time.monotonic(), before, name)
            elif listed is not None and time.monotonic() - listed >= ROGUE_STAYS:
                with soak.lock:
                    named = [t for t, text in soak.reports[before:] if name in text]
                latencies.append(named[0] - listed if named else None)
                core.stop(process)
                rogue = None
        if now >= next_sample:
            rss.append((round(now - started, 1), *(rss_kib(n.pid) for n in nodes)))
            next_sample += 1.0
        time.sleep(max(0.0, min(next_send, next_churn) - time.monotonic(), 0.001))
    for process in churning:
        core.stop(process)
    if rogue is not None:
        core.stop(rogue[0])
    return {"latencies": latencies, "rss": rss}


def main() -> None:
    logs, package, seconds = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3])
    scripts = package / "scripts"
    with core.roscore(logs):
        monitor = core.start([core.python(), str(scripts / "monitor")], logs / "monitor.log")
        watch = core.start([core.python(), str(scripts / "intrusion")], logs / "intrusion.log")
        codes: list[int | None] = [None, None]
        try:
            core.wait_for(lambda: core.publishes("/rmv_monitor", "/rmv/verdicts"), 30, "monitor")
            core.wait_for(lambda: core.subscribes("/rmv_monitor", TOPIC), 30, "monitor's reader")
            core.wait_for(lambda: core.publishes("/rmv_intrusion", "/rmv/intrusion"), 30,
                          "intrusion node")  # fmt: skip
            rospy.init_node("player", disable_signals=True)
            player = Soak(logs)
            core.wait_for(lambda: player.twist.get_num_connections() > 0, 30, "the twist reader")
            found = soak(player, seconds, [monitor, watch])
            time.sleep(2.0)  # the last messages reach the monitor
        finally:
            codes = [core.stop(monitor), core.stop(watch)]
        time.sleep(1.0)  # the last segments, published as the monitor stopped
        rospy.signal_shutdown("done")
    with player.lock:
        print(json.dumps({
            "sent": player.sent, "verdicts": player.verdicts,
            "reports": [text for _, text in player.reports], **found, "codes": codes,
            "log": (logs / "intrusion.log").read_text(errors="replace")[-4000:],
        }))  # fmt: skip


if __name__ == "__main__":
    main()
