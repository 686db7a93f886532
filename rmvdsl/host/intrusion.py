"""The intrusion node's work, with no ROS in it: each poll of the ROS graph (every
endpoint seen, as rclpy's graph API or the ROS 1 master and nodes give it)
becomes endpoints for the runtime, which checks them against the spec's
whitelists, node rules and `intrusion` block; intrusions become log lines and a
status, and registered nodes that no longer answer (ROS 1) a second one."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from rmvdsl.host.status import ERROR, OK, WARN, Status
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
# A ROS 1 connection no registration accounts for is judged once it lasts this
# long: a node that stops unregisters before it closes its connections, and one
# that starts connects just after registering, so for a moment either looks
# unregistered to a poll that reads the master and the nodes one after the other.
UNREGISTERED_GRACE = 1.0
# ... unless the peer it names no longer answers: a node that stopped, whose
# connection its subscriber keeps retrying for a while (rospy backs off up to 32 s),
# carries nothing. It is judged only if that lasts this long (a peer that closed its
# XML-RPC server yet still sends is caught all the same, later).
GONE_GRACE = 5.0
# A registered ROS 1 node that does not answer is stale once it has not answered
# this long: a node that stops closes its XML-RPC server around the time it
# unregisters, so a poll may catch it between the two, and a busy machine stretches
# that moment past a second: with 1 s, one of twenty nodes stopping beside a
# parallel test run was called stale.
STALE_GRACE = 3.0
# ... if its server refused the call (GONE: no process listens there). A call that
# timed out (SLOW) may be a live node on a loaded machine (an allowed node answering
# late for over 3 s was called stale beside a parallel test run), or a hung one: it
# is stale only once that lasts this long.
HUNG_GRACE = 15.0
# ... and only after this many polls in a row found it silent, so that one long
# stall of the poll itself (the machine busy) is not taken for the grace.
STALE_POLLS = 3
GONE, SLOW = "gone", "slow"  # how a registered node did not answer


@dataclass(frozen=True)
class Seen:
    """One endpoint of the graph, as the graph API reports it."""

    topic: str
    role: str  # publisher | subscriber
    node_namespace: str
    node_name: str
    gid: bytes
    registered: bool = True  # False: a connection the ROS 1 master never heard of
    answering: bool = True  # False: the unregistered peer's XML-RPC server does not answer

    @property
    def node(self) -> str:
        """Who: the node's full name (an unregistered peer: its address or the name
        it gave)."""
        if not self.registered:
            return self.node_name
        return full_name(self.node_namespace, self.node_name)

    @property
    def grace(self) -> float:
        """Seconds it must stay as it is before it is judged (0: judged at once)."""
        if not self.registered:
            return UNREGISTERED_GRACE if self.answering else GONE_GRACE
        return UNKNOWN_GRACE if self.node_name == UNKNOWN_NODE else 0.0


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
        # When each endpoint still in its grace was first seen: topic, role, gid, registered.
        self.provisional_since: dict[tuple[str, str, bytes, bool], float] = {}
        self.stale: list[str] = []
        # node -> when it first did not answer, and in how many polls in a row
        self.silent_since: dict[str, tuple[float, int]] = {}

    def endpoints(self, seen: Iterable[Seen], now: float, complete: bool = True) -> set[Endpoint]:
        """The endpoints to judge at monotonic time `now` (seconds). An endpoint in
        its grace that a `complete` poll no longer sees starts its grace again if it
        comes back; one that an incomplete poll (a node did not answer, so its
        connections went unseen) misses keeps it: on a busy machine a slow answer
        now and then would otherwise keep a sneak from ever being judged."""
        found: set[Endpoint] = set()
        provisional = {} if complete else dict(self.provisional_since)
        for endpoint in seen:
            if endpoint.grace:
                key = (endpoint.topic, endpoint.role, endpoint.gid, endpoint.registered)
                provisional[key] = since = self.provisional_since.get(key, now)
                if now - since < endpoint.grace:
                    continue  # judged only if it stays so
            if endpoint.node not in self.own:
                found.add(Endpoint(endpoint.node, endpoint.topic, endpoint.role,
                                   endpoint.registered))  # fmt: skip
        self.provisional_since = provisional
        return found

    def poll(
        self, time: int, seen: Iterable[Seen], now: float, silent: Mapping[str, str] | None = None
    ) -> list[tuple[str, str]]:
        """Judge the graph at `time` (the node's clock, nanoseconds), given the
        registered nodes that did not answer this time and how (`silent`: GONE or
        SLOW, stale once that has lasted its grace over STALE_POLLS polls, and their
        endpoints then no longer judged: a dead node carries no traffic); the log
        lines (level, text)."""
        lines = []
        silent = silent or {}
        silent_since = {}
        for node in sorted(set(silent) - self.own):
            since, polls = self.silent_since.get(node, (now, 0))
            silent_since[node] = (since, polls + 1)
        self.silent_since = silent_since
        stale = sorted(n for n in silent_since if self._is_stale(n, silent[n], now))
        for node in sorted(set(stale) - set(self.stale)):
            lines.append(("warn", _stale_line(node, silent[node])))
        self.stale = stale
        alive = [s for s in seen if not s.registered or s.node not in stale]
        self.runtime.graph(time, self.endpoints(alive, now, complete=not silent_since))
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

    def _is_stale(self, node: str, how: str, now: float) -> bool:
        since, polls = self.silent_since[node]
        grace = STALE_GRACE if how == GONE else HUNG_GRACE
        return polls >= STALE_POLLS and now - since >= grace

    def statuses(self) -> list[Status]:
        """The intrusions, and the registered nodes that do not answer."""
        stale = Status(
            NODE_NAME, "stale nodes", WARN if self.stale else OK,
            f"{counted(len(self.stale), 'node')} registered but not answering: "
            + ", ".join(self.stale) if self.stale else "every registered node answers",
            {node: "registered, not answering" for node in self.stale},
        )  # fmt: skip
        return [self.status(), stale]

    def status(self) -> Status:
        values = {
            f"{e.node} {e.role} {e.topic}": reason
            for e, reason in sorted(self.open.items(), key=lambda item: repr(item[0]))
        }
        # Who, in the message itself: a dashboard shows the message first.
        who = ", ".join(values)
        message = f"{counted(len(values), 'intrusion')}: {who}" if values else "no intrusion"
        return Status(NODE_NAME, "intrusions", ERROR if values else OK, message, values)


def _stale_line(node: str, how: str) -> str:
    if how == GONE:
        return f"stale: {node} is registered with the ROS master but does not answer (killed?)"
    return (f"stale: {node} is registered with the ROS master but has not answered "
            f"for {HUNG_GRACE:g} s (hung?)")  # fmt: skip
