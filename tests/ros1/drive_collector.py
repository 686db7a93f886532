"""Inside the namespace: roscore, a real influxd on 127.0.0.1 with the build's
schema, the kapacitor target's ROS 1 collector (run straight from its folder),
then `rosbag play` of a recording into it. Prints one JSON object: the points
stored per topic, the states stored, the collector's last status and its log.

usage: drive_collector.py LOGS SCENARIO_JSON
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

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from influx.server import Influxd


def main() -> None:
    logs = Path(sys.argv[1])
    scenario = json.loads(Path(sys.argv[2]).read_text(encoding="utf-8"))
    status: dict[str, str] = {}
    lock = threading.Lock()
    database, measurement = scenario["database"], scenario["measurement"]
    influxd = Influxd(Path(scenario["influx_root"]), run_interval="1h")
    try:
        for statement in scenario["statements"]:
            influxd.query(statement)
        with core.roscore(logs):
            command = [core.python(), scenario["collector"], f"_influx_url:={influxd.url}",
                       "_diagnostics_period:=0.2"]  # fmt: skip
            collector = core.start(command, logs / "collector.log")
            try:
                core.wait_for(lambda: core.subscribes("/rmv_collector", scenario["topic"]), 30,
                              "the collector")  # fmt: skip
                rospy.init_node("rmv_test_listener", disable_signals=True)

                def diagnostics(message: DiagnosticArray) -> None:
                    for item in message.status:
                        if item.name == "rmv_collector: influxdb":
                            with lock:
                                status.clear()
                                status.update({v.key: v.value for v in item.values})
                                status["_message"] = item.message

                rospy.Subscriber("/diagnostics", DiagnosticArray, diagnostics, queue_size=None)
                play = subprocess.run(
                    ["rosbag", "play", "--wait-for-subscribers", "-r", "10", scenario["bag"]],
                    capture_output=True, text=True, timeout=300,
                )  # fmt: skip
                (logs / "play.log").write_text(play.stdout + play.stderr)

                def stored() -> int:
                    rows = influxd.points(f'SELECT count(*) FROM "{measurement}"', database)
                    return max((max(r[1:]) for r in rows), default=0)

                try:
                    core.wait_for(lambda: stored() >= scenario["expected"], 30, "every point", 0.2)
                except TimeoutError as timeout:
                    with lock:
                        found = f"{stored()} stored, status {status}"
                    raise TimeoutError(f"{timeout}: {found}") from None
                time.sleep(1.0)  # nothing more comes
            finally:
                code = core.stop(collector)
            rospy.signal_shutdown("done")
            grouped = f'SELECT * FROM "{measurement}" GROUP BY "topic"'
            topics = influxd.query(grouped, database)[0].get("series", [])
            states = influxd.points(f'SELECT * FROM "{scenario["states"]}"', database)
    finally:
        influxd.stop()
    with lock:
        print(json.dumps({
            "per_topic": {s["tags"]["topic"]: len(s["values"]) for s in topics},
            "states": len(states), "status": status, "exit": code,
            "play_exit": play.returncode,
            "log": (logs / "collector.log").read_text(errors="replace")[-4000:],
        }))  # fmt: skip


if __name__ == "__main__":
    main()
