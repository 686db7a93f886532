"""The load side of benchmarks/bench_ros1.py, run inside the private network
namespace by the .ros1-venv Python (Debian's rospy), with a roscore of its own.

    ros1_load.py LOGS rate COMMAND_JSON COUNT
    ros1_load.py LOGS latency COMMAND_JSON HZ COUNT
    ros1_load.py LOGS workload COMMAND_JSON BAG
    ros1_load.py bare MODE          (the bare subscriber: MODE count or echo)

COMMAND_JSON starts the reader under test: the generated monitor, or this
script's bare AnyMsg subscriber. Prints one JSON object of figures.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "ros1"))
import core
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from std_msgs.msg import String, UInt64

TOPIC = "/bench/status"
TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


class Reader:
    """What the reader under test says: the monitor's diagnostics counters, its
    verdict segments; the bare subscriber's count and echoes."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.counted = 0
        self.counters: dict[str, str] = {}
        self.answers: list[int] = []  # arrival times of verdicts or echoes (ns)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.diagnostics, queue_size=None)
        rospy.Subscriber("/bench/count", UInt64, self.count, queue_size=None)
        for topic in ("/rmv/verdicts", "/bench/echo"):
            rospy.Subscriber(topic, String, self.answer, queue_size=None, tcp_nodelay=True)

    def diagnostics(self, message: DiagnosticArray) -> None:
        for status in message.status:
            if status.name == "rmv_monitor: monitor":
                values = {v.key: v.value for v in status.values}
                with self.lock:
                    self.counters = values
                    self.counted = int(values.get("messages", 0))

    def count(self, message: UInt64) -> None:
        with self.lock:
            self.counted = message.data

    def answer(self, _: String) -> None:
        now = time.time_ns()
        with self.lock:
            self.answers.append(now)


def twist(k: int, speed: float) -> TwistStamped:
    message = TwistStamped()
    message.header.stamp = rospy.Time(1_700_000_000 + k // 1000, (k % 1000) * 1_000_000)
    message.twist.linear.x = speed
    return message


def start_reader(
    logs: Path, command: list[str]
) -> tuple[subprocess.Popen, Reader, rospy.Publisher]:
    process = core.start(command, logs / "reader.log")
    core.wait_for(lambda: any(t == TOPIC and ns for t, ns in core.system_state()[1]), 60, "reader")
    rospy.init_node("rmv_bench_load", disable_signals=True)
    reader = Reader()
    publisher = rospy.Publisher(TOPIC, TwistStamped, queue_size=100_000, tcp_nodelay=True)
    core.wait_for(lambda: publisher.get_num_connections() > 0, 30, "connection")
    time.sleep(1.0)  # the reader's publishers and ours meet
    return process, reader, publisher


def rate(logs: Path, command: list[str], count: int) -> dict:
    process, reader, publisher = start_reader(logs, command)
    cpu = cpu_seconds(process.pid)
    start = time.monotonic()
    for k in range(count):
        publisher.publish(twist(k, float(k % 7)))
    core.wait_for(lambda: reader.counted >= count, 120, f"{count} messages read", 0.01)
    wall = time.monotonic() - start
    used = cpu_seconds(process.pid) - cpu
    core.stop(process)
    return {
        "messages": count,
        "wall": wall,
        "cpu": used,
        "per_second": count / wall,
        "per_cpu_second": count / used if used else None,
        "counters": reader.counters,
    }


def latency(logs: Path, command: list[str], hz: float, count: int) -> dict:
    """Speeds alternate, so every message ends the segment before it: the k-th
    answer (verdict or echo) answers message k (bare) or k + 1 (monitor)."""
    process, reader, publisher = start_reader(logs, command)
    sent: list[int] = []
    period = 1.0 / hz
    due = time.monotonic()
    for k in range(count):
        due += period
        time.sleep(max(0.0, due - time.monotonic()))
        sent.append(time.time_ns())
        publisher.publish(twist(k, 10.0 if k % 2 else 0.0))
    time.sleep(1.0)
    core.stop(process)
    shift = 1 if "monitor" in " ".join(command) else 0
    with reader.lock:
        answers = list(reader.answers)
    delays = sorted(a - s for a, s in zip(answers, sent[shift:], strict=False))
    if len(delays) < count - 1 - shift:
        raise SystemExit(f"only {len(delays)} answers to {count} messages")
    return {
        "hz": hz,
        "messages": count,
        "answers": len(delays),
        "p50_ms": delays[len(delays) // 2] / 1e6,
        "p99_ms": delays[int(len(delays) * 0.99)] / 1e6,
        "counters": reader.counters,
    }


def workload(logs: Path, command: list[str], bag: str) -> dict:
    process = core.start(command, logs / "reader.log")
    core.wait_for(lambda: any(ns for t, ns in core.system_state()[1] if t.startswith("/carla")),
                  60, "monitor")  # fmt: skip
    rospy.init_node("rmv_bench_load", disable_signals=True)
    reader = Reader()
    cpu, start = cpu_seconds(process.pid), time.monotonic()
    play = core.start(["rosbag", "play", "--wait-for-subscribers", "-q", bag], logs / "play.log")
    peak = 0.0
    while play.poll() is None:
        peak = max(peak, rss_mb(process.pid))
        time.sleep(0.5)
    time.sleep(1.0)
    used, wall = cpu_seconds(process.pid) - cpu, time.monotonic() - start
    core.stop(process)
    return {
        "wall": wall,
        "cpu": used,
        "cpu_share": used / wall,
        "peak_rss_mb": peak,
        "counters": reader.counters,
    }


def bare(mode: str) -> None:
    """A bare rospy AnyMsg subscriber: counts (published every 50 ms) or echoes."""
    rospy.init_node("rmv_bench_bare", disable_signals=True)
    counted = [0]
    echo = rospy.Publisher("/bench/echo", String, queue_size=10_000, tcp_nodelay=True)
    count = rospy.Publisher("/bench/count", UInt64, queue_size=10)

    def received(_: rospy.AnyMsg) -> None:
        counted[0] += 1
        if mode == "echo":
            echo.publish(String(data="x"))

    rospy.Subscriber(TOPIC, rospy.AnyMsg, received, queue_size=None, tcp_nodelay=True)
    stop = threading.Event()
    import signal

    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: stop.set())
    while not stop.wait(0.05):
        count.publish(UInt64(data=counted[0]))
    rospy.signal_shutdown("stopped")


def main() -> None:
    if sys.argv[1] == "bare":
        bare(sys.argv[2])
        return
    logs, mode, command = Path(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3])
    with core.roscore(logs):
        if mode == "rate":
            result = rate(logs, command, int(sys.argv[4]))
        elif mode == "latency":
            result = latency(logs, command, float(sys.argv[4]), int(sys.argv[5]))
        else:
            result = workload(logs, command, sys.argv[4])
        rospy.signal_shutdown("done")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
