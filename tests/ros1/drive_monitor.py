"""Inside the namespace: roscore, the generated monitor (started first: a late
subscriber loses messages), a subscriber to its verdicts, then `rosbag play` of a
recording into it. Prints one JSON object: the verdict segments in the order
published, the monitor's last diagnostics values and its log.

usage: drive_monitor.py LOGS PACKAGE_DIR BAG [--node NAME] [--sim] [--arg ARG]...
                        [-- ROSBAG_ARGS...]

--node: the monitor's node name (it is started with `__name:=NAME` when not the
default); --sim: `/use_sim_time` is set and the player publishes /clock; --arg:
one more command-line argument of the monitor (`_name:=value`).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import threading
import time
from pathlib import Path

import core
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from std_msgs.msg import String


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("logs", type=Path)
    parser.add_argument("package", type=Path)
    parser.add_argument("bag", type=Path)
    parser.add_argument("--node", default="/rmv_monitor")
    parser.add_argument("--sim", action="store_true")
    parser.add_argument("--arg", action="append", default=[])
    parser.add_argument("--late", action="append", default=[], help="a topic to read after")
    options, play_args = parser.parse_known_args()
    play_args = [a for a in play_args if a != "--"]
    logs, package, bag, node = options.logs, options.package, options.bag, options.node
    arguments = list(options.arg)
    if node != "/rmv_monitor":
        arguments.append(f"__name:={node.lstrip('/')}")
    if options.sim:
        play_args.append("--clock")
    verdicts: list[dict] = []
    late: dict[str, list[str]] = {}
    counters: dict[str, str] = {}
    lock = threading.Lock()
    with core.roscore(logs):
        if options.sim:
            core.set_param("/use_sim_time", True)
        monitor = core.start(
            [core.python(), str(package / "scripts" / "monitor"), *arguments], logs / "monitor.log"
        )
        try:
            core.wait_for(lambda: core.publishes(node, "/rmv/verdicts"), 30, "monitor")
            state = core.system_state()[0]
            publishers = sorted(n for t, ns in state for n in ns if t == "/rmv/verdicts")
            rospy.init_node("rmv_test_listener", disable_signals=True)

            def verdict(message: String) -> None:
                with lock:
                    verdicts.append(json.loads(message.data))

            def diagnostics(message: DiagnosticArray) -> None:
                for status in message.status:
                    if status.name.endswith(": monitor"):
                        with lock:
                            counters.clear()
                            counters.update({v.key: v.value for v in status.values})

            listener = rospy.Subscriber("/rmv/verdicts", String, verdict, queue_size=None)
            rospy.Subscriber("/diagnostics", DiagnosticArray, diagnostics, queue_size=None)
            core.wait_for(lambda: listener.get_num_connections() > 0, 30, "verdict connection")
            play = subprocess.run(
                ["rosbag", "play", "--wait-for-subscribers", *play_args, str(bag)],
                capture_output=True,
                text=True,
                timeout=300,
            )
            (logs / "play.log").write_text(play.stdout + play.stderr)
            time.sleep(1.5)  # the last messages reach the monitor, diagnostics come
            for topic in options.late:  # what a subscriber that comes now still gets
                got = late[topic] = []
                rospy.Subscriber(topic, String, lambda m, got=got: got.append(m.data))
                core.wait_for(lambda got=got: bool(got), 10, f"the latched {topic}")
        finally:
            code = core.stop(monitor)
        time.sleep(1.0)  # the last segments, published as the monitor stopped
        rospy.signal_shutdown("done")
    with lock:
        print(
            json.dumps(
                {
                    "verdicts": verdicts,
                    "counters": counters,
                    "monitor_exit": code,
                    "play_exit": play.returncode,
                    "verdict_publishers": publishers,
                    "late": late,
                    "monitor_log": (logs / "monitor.log").read_text(errors="replace")[-4000:],
                }
            )
        )


if __name__ == "__main__":
    main()
