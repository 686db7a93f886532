"""Inside the namespace: roscore, the generated monitor (started first: a late
subscriber loses messages), a subscriber to its verdicts, then `rosbag play` of a
recording into it. Prints one JSON object: the verdict segments in the order
published, the monitor's last diagnostics values and its log.

usage: drive_monitor.py LOGS PACKAGE_DIR BAG [ROSBAG_ARGS...]
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import core
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from std_msgs.msg import String


def main() -> None:
    logs, package, bag = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    play_args = sys.argv[4:]
    verdicts: list[dict] = []
    counters: dict[str, str] = {}
    lock = threading.Lock()
    with core.roscore(logs):
        monitor = core.start(
            [core.python(), str(package / "scripts" / "monitor")], logs / "monitor.log"
        )
        try:
            core.wait_for(lambda: core.publishes("/rmv_monitor", "/rmv/verdicts"), 30, "monitor")
            rospy.init_node("rmv_test_listener", disable_signals=True)

            def verdict(message: String) -> None:
                with lock:
                    verdicts.append(json.loads(message.data))

            def diagnostics(message: DiagnosticArray) -> None:
                for status in message.status:
                    if status.name == "rmv_monitor: monitor":
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
                    "monitor_log": (logs / "monitor.log").read_text(errors="replace")[-4000:],
                }
            )
        )


if __name__ == "__main__":
    main()
