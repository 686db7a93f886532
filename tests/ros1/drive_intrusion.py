"""Inside the namespace: roscore, the generated intrusion node, allowed nodes, then
in turn: churn (allowed nodes starting and stopping), a rogue publisher, a rogue
subscriber, a publisher that skips the master, an allowed node frozen with SIGSTOP
for longer than the stale grace (its calls time out: late, not gone), and a node
killed with SIGKILL.
Prints one JSON object: when each step happened and every status the node put
on /diagnostics (monotonic seconds), and its log.

usage: drive_intrusion.py LOGS PACKAGE_DIR TOPIC CHURN_NODES
"""

from __future__ import annotations

import json
import signal
import sys
import threading
import time
from pathlib import Path

import core
import rospy
from diagnostic_msgs.msg import DiagnosticArray

HERE = Path(__file__).resolve().parent


def main() -> None:
    logs, package, topic, churn = (
        Path(sys.argv[1]),
        Path(sys.argv[2]),
        sys.argv[3],
        int(sys.argv[4]),
    )
    statuses: list[dict] = []
    steps: dict[str, float] = {}
    lock = threading.Lock()
    peers = []
    names: dict[int, str] = {}  # pid -> node name
    exits: dict[str, int] = {}  # node name -> exit code (0: stopped cleanly)

    def peer(name: str, role: str, *extra: str):
        process = core.start(
            [core.python(), str(HERE / "peer.py"), name, role, topic, *extra],
            logs / f"{name.strip('/')}.log",
        )
        peers.append(process)
        names[process.pid] = name
        return process

    def stop(process) -> None:
        """Stop a peer; its exit is kept (a peer killed after 15 s stays registered,
        and so is rightly reported stale)."""
        exits[names[process.pid]] = core.stop(process)

    def registered(name: str, role: str) -> bool:
        return (core.publishes if role == "publisher" else core.subscribes)(name, topic)

    with core.roscore(logs):
        guard = core.start(
            [core.python(), str(package / "scripts" / "intrusion")], logs / "intrusion.log"
        )
        try:
            rospy.init_node("rmv_test_listener", disable_signals=True)

            def diagnostics(message: DiagnosticArray) -> None:
                now = time.monotonic()
                with lock:
                    for status in message.status:
                        statuses.append(
                            {
                                "t": now,
                                "name": status.name,
                                "level": int(status.level),
                                "message": status.message,
                                "values": {v.key: v.value for v in status.values},
                            }
                        )

            rospy.Subscriber("/diagnostics", DiagnosticArray, diagnostics, queue_size=None)
            core.wait_for(lambda: bool(statuses), 30, "the intrusion node's diagnostics")
            peer("/driver", "publisher")
            peer("/base", "subscriber")
            core.wait_for(lambda: registered("/driver", "publisher"), 10, "/driver")
            core.wait_for(lambda: registered("/base", "subscriber"), 10, "/base")
            time.sleep(1.0)
            steps["churn"] = time.monotonic()
            running = []
            for k in range(churn):
                role = "publisher" if k % 2 else "subscriber"
                running.append(peer(f"/allowed_{k}", role))
                time.sleep(0.25)
                if len(running) > 4:
                    stop(running.pop(0))
            for process in running:
                stop(process)
            time.sleep(2.0)
            steps["churn end"] = time.monotonic()
            for name, role in (("/rogue_pub", "publisher"), ("/rogue_sub", "subscriber")):
                steps[f"{name} start"] = time.monotonic()
                process = peer(name, role)
                core.wait_for(lambda n=name, r=role: registered(n, r), 10, name)
                steps[name] = time.monotonic()
                time.sleep(3.0)
                stop(process)
            steps["sneak start"] = time.monotonic()
            sneak = peer("/sneak", "sneak", "/base")
            core.wait_for(lambda: "sneaked" in (logs / "sneak.log").read_text(), 10, "sneak")
            steps["sneak"] = time.monotonic()
            steps["sneak uri"] = (logs / "sneak.log").read_text().split("sneaked ")[1].split()[0]
            # long enough that a report later than the 2 s asked shows when it came
            time.sleep(6.0)
            stop(sneak)
            frozen = peer("/allowed_frozen", "publisher")
            core.wait_for(lambda: registered("/allowed_frozen", "publisher"), 10, "frozen")
            time.sleep(1.0)
            frozen.send_signal(signal.SIGSTOP)
            steps["frozen"] = time.monotonic()
            time.sleep(6.0)  # past the stale grace (3 s) and its polls, short of 15 s
            frozen.send_signal(signal.SIGCONT)
            steps["thawed"] = time.monotonic()
            time.sleep(1.0)
            stop(frozen)
            victim = peer("/victim", "subscriber")
            core.wait_for(lambda: registered("/victim", "subscriber"), 10, "/victim")
            time.sleep(1.0)
            victim.send_signal(signal.SIGKILL)
            victim.wait()
            steps["victim killed"] = time.monotonic()
            time.sleep(5.0)  # past its stale grace (3 s) and a poll
        finally:
            for process in peers:
                stop(process)
            code = core.stop(guard)
            rospy.signal_shutdown("done")
    with lock:
        print(
            json.dumps(
                {
                    "steps": steps,
                    "statuses": statuses,
                    "exit": code,
                    "peer exits": exits,
                    "log": (logs / "intrusion.log").read_text(errors="replace")[-6000:],
                }
            )
        )


if __name__ == "__main__":
    main()
