"""ROS 1 wiring of the host: rospy nodes whose callbacks call monitor.py,
intrusion.py and collector.py. The one module of rmv_host that imports rospy; the
generated package's scripts only call `monitor_main`, `intrusion_main` or
`collector_main` (tests/test_ros1.py runs them on Debian's ROS 1).

Every topic is read as `rospy.AnyMsg` and decoded by ros1_decoding.py from the
definition in the connection header, so no Python message of the spec's types
needs to be installed; the intrusion node reads the master and the nodes over
XML-RPC (ros1_graph.py). Private parameters (`_name:=value`, or the launch file's
`config/params.yaml`) hold what the ROS 2 nodes' parameters hold, with `/` for
the ROS 2 names' `.` (`~topics/NAME`, `~time/NAME`).
"""

from __future__ import annotations

import faulthandler
import signal
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

import rosgraph
import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import String

from rmvdsl.host import (
    collector,
    intrusion,
    monitor,
    partial_decoding,
    ros1_decoding,
    ros1_graph,
)
from rmvdsl.host.actions import NodeActions
from rmvdsl.host.gaps import Undecodable
from rmvdsl.host.packaged import load_spec, package, with_time_sources
from rmvdsl.host.status import ERROR, OK, STALE, WARN, Status, fill_diagnostics
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import visible

LEVELS = {
    OK: DiagnosticStatus.OK, WARN: DiagnosticStatus.WARN, ERROR: DiagnosticStatus.ERROR,
    STALE: DiagnosticStatus.STALE,
}  # fmt: skip
# Seconds the node waits after its last segments, for rospy's publisher threads.
FLUSH = 0.5


def parameter(name: str, default: Any) -> Any:
    """The node's private parameter `name` (a `.` of the ROS 2 name is a `/`)."""
    return rospy.get_param("~" + name.replace(".", "/"), default)


def now_ns() -> int:
    """The node's clock: `/clock` under `/use_sim_time`, else the system's."""
    return int(rospy.get_rostime().to_nsec())


def log_at(level: str, text: str) -> None:
    """Log at a level named at run time, safe for a terminal: a ROS 1 node's name
    is any caller id it registered, and an intrusion's line names it."""
    {"debug": rospy.logdebug, "info": rospy.loginfo, "warn": rospy.logwarn,
     "error": rospy.logerr}.get(level, rospy.logfatal)(visible(text))  # fmt: skip


def diagnostics(statuses: list[Status]) -> DiagnosticArray:
    array = DiagnosticArray()
    array.header.stamp = rospy.Time.now()
    classes = (DiagnosticStatus, KeyValue)
    filled: DiagnosticArray = fill_diagnostics(array, statuses, classes, LEVELS, package())
    return filled


def node_actions(spec: ir.Spec) -> NodeActions:
    """The actions as a rospy node takes them. `publish` topics are latched (the
    last message waits for subscribers that come later) and advertised at start."""

    def advertise(topic: str) -> rospy.Publisher:
        return rospy.Publisher(topic, String, queue_size=100, latch=True)

    publishers = {topic: advertise(topic) for topic in ir.published_topics(spec)}

    def publish(topic: str, text: str) -> None:
        if topic not in publishers:
            publishers[topic] = advertise(topic)
        publishers[topic].publish(String(data=text))

    return NodeActions(log_at, publish)


def subscribe(spec: ir.Spec, take: Callable[[str, Any, dict[str, Any]], None]) -> None:
    """Every topic of the spec as raw bytes, decoded here: `take(topic, message,
    info)` names the topic as the spec does; a message not of the spec's type, or
    not decodable, is an `Undecodable`. `info` holds the publisher and its header's
    `seq`, from which monitor.Gaps counts lost messages."""
    problem = ros1_decoding.missing()
    if problem is not None:
        raise SystemExit(f"{rospy.get_name()}: {problem}")
    # each topic's fields the spec reads, and its header's `seq` (monitor.Gaps)
    decoder = ros1_decoding.Decoder(optional={"header": {"seq": None}})
    variables: dict[str, list[ir.Variable]] = {}
    for variable in spec.variables:
        variables.setdefault(variable.topic, []).append(variable)
    # what is read of each topic; and of it but the variables a publisher's
    # definition does not give (kept: the decoder knows needs by their identity)
    everything = partial_decoding.spec_needs(spec)
    needs_without: dict[frozenset[str], dict[str, partial_decoding.Needs]] = {}

    def needs(ros_name: str, unread: dict[str, str]) -> partial_decoding.Needs | None:
        if not unread:
            return everything.get(ros_name)
        skipped = frozenset(unread)
        if skipped not in needs_without:
            needs_without[skipped] = partial_decoding.spec_needs(spec, skipped)
        return needs_without[skipped].get(ros_name)

    for topic in spec.topics:
        ros_name = str(parameter(f"topics.{topic.name}", topic.ros_name))
        reads = variables.get(topic.name)

        def received(
            raw: rospy.AnyMsg,
            topic: ir.Topic = topic,
            ros_name: str = ros_name,
            read: list[ir.Variable] | None = reads,
        ) -> None:
            header = getattr(raw, "_connection_header", None) or {}
            info: dict[str, Any] = {
                "publisher_gid": {"data": header.get("callerid")},
                "received_timestamp": time.time_ns(),  # for the latency figures
            }
            sent = decoder.message_type(header)
            message: Any = None  # a topic no variable reads (a whitelist's): not decoded
            if sent != topic.message_type:
                message = Undecodable(f"its publisher sends {sent} on {ros_name}, the spec "
                                      f"reads {topic.message_type}")  # fmt: skip
            elif read:
                unread = decoder.unread(header, read, topic.ros_name)
                if unread:
                    info["unread"] = unread
                try:
                    wanted = needs(topic.ros_name, unread)
                    message = decoder.decode(header, raw._buff, wanted)
                except ros1_decoding.DecodeError as error:
                    message = Undecodable(str(error))
                else:
                    info["publication_sequence_number"] = _sequence(message)
            take(topic.ros_name, message, info)

        depth = topic.qos.depth if topic.qos.history != "keep_all" else None
        rospy.Subscriber(ros_name, rospy.AnyMsg, received, queue_size=depth, tcp_nodelay=True)


def _sequence(message: Any) -> int | None:
    """A ROS 1 header's `seq` (set by the publisher, one more each message)."""
    sequence = getattr(getattr(message, "header", None), "seq", None)
    return sequence if isinstance(sequence, int) else None


class RosNode(Protocol):
    def spin(self, stop: threading.Event) -> None: ...

    def finish(self) -> None: ...


class MonitorNode:
    """The spec's topics in, verdict segments on /rmv/verdicts, a DiagnosticArray on
    /diagnostics, the actions: monitor.Monitor does the work."""

    def __init__(self, spec: ir.Spec) -> None:
        verdict_topic = str(parameter("verdict_topic", "/rmv/verdicts"))
        self.verdicts = rospy.Publisher(verdict_topic, String, queue_size=10_000)
        self.diagnostics = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=10)
        spec = with_time_sources(spec, parameter, rospy.get_name())
        self.monitor = monitor.Monitor(
            spec, node_actions(spec), self, now_ns,
            decide_period=float(parameter("decide_period", 0.1)),
            diagnostics_period=float(parameter("diagnostics_period", 1.0)),
            queue_depth=int(parameter("queue_depth", 100_000)), ros_version=1,
        )  # fmt: skip
        subscribe(spec, self.monitor.take)
        self.monitor.start()

    # monitor.Outputs
    def verdict(self, text: str) -> None:
        self.verdicts.publish(String(data=text))

    def statuses(self, statuses: list[Status]) -> None:
        self.diagnostics.publish(diagnostics(statuses))

    def warn(self, text: str) -> None:
        log_at("warn", text)

    def spin(self, stop: threading.Event) -> None:
        stop.wait()

    def finish(self) -> None:
        self.monitor.finish()


class IntrusionNode:
    """Reads the graph every `poll` seconds (the steady clock: the graph changes in
    real time, simulated or not) and reports what intrusion.IntrusionWatch finds.
    The monitor's node (`~monitor_node`, default /rmv_monitor) and this one are
    never judged."""

    def __init__(self, spec: ir.Spec) -> None:
        self.period = float(parameter("poll", float(spec.intrusion.poll)))
        own = (rospy.get_name(), str(parameter("monitor_node", "/" + monitor.NODE_NAME)))
        self.watch = intrusion.IntrusionWatch(spec, node_actions(spec), own, ros_version=1)
        self.diagnostics = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=10)
        self.graph = ros1_graph.Reader(rosgraph.get_master_uri(), rospy.get_name())
        self.unreachable = False

    def poll(self) -> None:
        try:
            graph = self.graph.read()
        except ros1_graph.MasterError as error:
            if not self.unreachable:
                log_at("error", str(error))
            self.unreachable = True
            return
        self.unreachable = False
        seen = graph.registered + graph.unregistered
        for level, text in self.watch.poll(now_ns(), seen, time.monotonic(), graph.silent):
            log_at(level, text)
        self.diagnostics.publish(diagnostics(self.watch.statuses()))

    def spin(self, stop: threading.Event) -> None:
        next_poll = time.monotonic()
        while not stop.wait(max(0.0, next_poll - time.monotonic())):
            self.poll()
            next_poll = max(next_poll + self.period, time.monotonic())

    def finish(self) -> None:
        pass


class CollectorNode:
    """The spec's topics into InfluxDB: collector.Collector does the work; the
    spec's `database` block gives the defaults of the parameters."""

    def __init__(self, spec: ir.Spec) -> None:
        assert spec.database is not None  # the kapacitor target builds no collector without
        settings = collector.settings(spec.database, parameter)
        self.period = float(parameter("diagnostics_period", 1.0))
        spec = with_time_sources(spec, parameter, rospy.get_name())
        self.collector = collector.Collector(spec, settings, self, now_ns)
        self.diagnostics = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=10)
        subscribe(spec, self.collector.take)
        self.collector.start()

    # collector.Logs
    def log(self, level: str, text: str) -> None:
        log_at(level, text)

    def spin(self, stop: threading.Event) -> None:
        while not stop.wait(self.period):
            self.diagnostics.publish(diagnostics([self.collector.tick()]))

    def finish(self) -> None:
        self.diagnostics.publish(diagnostics([self.collector.finish()]))


def run(make: Callable[[ir.Spec], RosNode], name: str) -> None:
    """Start a node (renamed by `__name:=`), run it until SIGINT, SIGTERM or a
    shutdown ROS asks for, then let it finish and leave."""
    rospy.init_node(name, disable_signals=True)
    # a node that does not stop can be asked where it is: `kill -USR1 PID` writes
    # every thread's stack to its log
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    node = make(load_spec())
    stop = threading.Event()
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: stop.set())
    rospy.on_shutdown(stop.set)
    try:
        node.spin(stop)
        node.finish()
        time.sleep(FLUSH)  # let the last messages leave
    finally:
        rospy.signal_shutdown("stopped")


def monitor_main() -> None:
    run(MonitorNode, monitor.NODE_NAME)


def intrusion_main() -> None:
    run(IntrusionNode, intrusion.NODE_NAME)


def collector_main() -> None:
    run(CollectorNode, collector.NODE_NAME)
