"""Inside the namespace: roscore, then `roslaunch PACKAGE monitor.launch` from a
catkin workspace's install space; and the package's monitor started by Debian's
own Python, which has no rosbags. Prints one JSON object: the nodes the launch
registered, a parameter it loaded, and how the bare Python's monitor ended.

usage: drive_launch.py LOGS WORKSPACE PACKAGE
"""

from __future__ import annotations

import json
import subprocess
import sys
import xmlrpc.client
from pathlib import Path

import core


def main() -> None:
    logs, workspace, package = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
    setup = workspace / "install" / "setup.bash"
    with core.roscore(logs):
        launch = core.start(
            ["bash", "-c", f'. "{setup}" && exec roslaunch {package} monitor.launch'],
            logs / "roslaunch.log",
        )
        try:
            core.wait_for(lambda: core.publishes("/rmv_monitor", "/rmv/verdicts"), 60, "monitor")
            core.wait_for(lambda: core.publishes("/rmv_intrusion", "/diagnostics"), 60, "guard")
            master = xmlrpc.client.ServerProxy(core.master_uri())
            _, _, topic = master.getParam("/test", "/rmv_monitor/topics/vehicle_status")
            nodes = sorted({n for _, ns in core.system_state()[0] for n in ns})
        finally:
            launched = core.stop(launch)
        bare = subprocess.run(
            ["/usr/bin/python3", str(workspace / "src" / package / "scripts" / "monitor")],
            capture_output=True, text=True, timeout=60,
        )  # fmt: skip
    print(json.dumps({
        "nodes": nodes, "topic parameter": topic, "launch_exit": launched,
        "bare_exit": bare.returncode, "bare_output": bare.stdout + bare.stderr,
        "log": (logs / "roslaunch.log").read_text(errors="replace")[-3000:],
    }))  # fmt: skip


if __name__ == "__main__":
    main()
