"""The intrusion node's work, with no ROS in it: each poll of the ROS graph (every
endpoint seen, as rclpy's graph API gives it) becomes endpoints for the runtime,
which checks them against the spec's whitelists, node rules and `intrusion` block;
intrusions become log lines and a status."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from rmvdsl.host.status import ERROR, OK, Status
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Endpoint, Host, Runtime
from rmvdsl.runtime.wording import counted

NODE_NAME = "rmv_intrusion"
# What DDS names an endpoint that no ROS node created.
BARE_DDS = "_CREATED_BY_BARE_DDS_APP_"
# What rmw names an endpoint whose node it has not learnt yet: during discovery a
# writer can be seen before its node's announcement. Such an endpoint is judged
# only if it stays unnamed this long (an allowed node is named well before).
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"
UNKNOWN_GRACE = 3.0


@dataclass(frozen=True)
class Seen:
    """One endpoint of the graph, as the graph API reports it."""

    topic: str
    role: str  # publisher | subscriber
    node_namespace: str
    node_name: str
    gid: bytes


def full_name(namespace: str, name: str) -> str:
    if name == BARE_DDS:
        return name
    return f"{namespace.rstrip('/')}/{name}"


class IntrusionWatch:
    """`own`: the node names of the monitor itself, never judged."""

    def __init__(
        self, spec: ir.Spec, actions: Host, own: Iterable[str], ros_version: int = 2
    ) -> None:
        self.runtime = Runtime(spec, actions, record=(), ros_version=ros_version)
        self.own = frozenset(own)
        self.open: dict[Endpoint, str] = {}
        self.unnamed_since: dict[tuple[str, str, bytes], float] = {}  # topic, role, gid

    def endpoints(self, seen: Iterable[Seen], now: float) -> set[Endpoint]:
        """The endpoints to judge at monotonic time `now` (seconds)."""
        found, unnamed = set(), {}
        for endpoint in seen:
            node = full_name(endpoint.node_namespace, endpoint.node_name)
            if endpoint.node_name == UNKNOWN_NODE:
                key = (endpoint.topic, endpoint.role, endpoint.gid)
                unnamed[key] = since = self.unnamed_since.get(key, now)
                if now - since < UNKNOWN_GRACE:
                    continue  # not named yet: judged only if it stays so
            if node not in self.own:
                found.add(Endpoint(node, endpoint.topic, endpoint.role))
        self.unnamed_since = unnamed
        return found

    def poll(self, time: int, seen: Iterable[Seen], now: float) -> list[tuple[str, str]]:
        """Judge the graph at `time` (the node's clock, nanoseconds); the log lines
        (level, text) it gives."""
        self.runtime.graph(time, self.endpoints(seen, now))
        lines = []
        for record in self.runtime.records():
            if record["kind"] != "intrusion":
                continue
            endpoint = Endpoint(record["node"], record["topic"], record["role"])
            if record["phase"] == "start":
                self.open[endpoint] = record["reason"]
                # Who, then what and where, each once (the actions' text says the same).
                lines.append(("error", f"intrusion: {endpoint.node} {record['reason']}"))
            else:
                self.open.pop(endpoint, None)
                lines.append(("info", f"intrusion ended: {endpoint.node} on {endpoint.topic}"))
        return lines

    def status(self) -> Status:
        values = {
            f"{e.node} {e.role} {e.topic}": reason
            for e, reason in sorted(self.open.items(), key=lambda item: repr(item[0]))
        }
        message = counted(len(values), "intrusion") if values else "no intrusion"
        return Status(NODE_NAME, "intrusions", ERROR if values else OK, message, values)
