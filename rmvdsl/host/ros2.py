"""ROS 2 wiring of the host: rclpy nodes whose callbacks call monitor.py,
intrusion.py and collector.py. The one module of rmv_host that imports ROS; the
generated package's node modules only call `monitor_main`, `intrusion_main` or
`collector_main` (tests/test_ros2.py runs them as colcon installs them)."""

from __future__ import annotations

import functools
import os
import signal
import threading
import time
from collections.abc import Callable
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    LivelinessPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String

from rmvdsl.host import collector, intrusion, monitor, ros2_definitions
from rmvdsl.host.actions import NodeActions
from rmvdsl.host.gaps import TypeWatch
from rmvdsl.host.packaged import load_spec, package, use_discovery_profile, with_time_sources
from rmvdsl.host.status import ERROR, OK, STALE, WARN, Status, fill_diagnostics
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import visible

LEVELS = {
    OK: DiagnosticStatus.OK, WARN: DiagnosticStatus.WARN, ERROR: DiagnosticStatus.ERROR,
    STALE: DiagnosticStatus.STALE,
}  # fmt: skip
# What a `publish` action writes is kept for late subscribers: the last 100 messages,
# reliable and transient_local (subscribe with transient_local to get them).
ACTION_QOS = QoSProfile(
    depth=100,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


def qos_profile(qos: ir.Qos) -> QoSProfile:
    profile = QoSProfile(
        depth=qos.depth,
        history=HistoryPolicy.KEEP_ALL if qos.history == "keep_all" else HistoryPolicy.KEEP_LAST,
        reliability=(
            ReliabilityPolicy.BEST_EFFORT
            if qos.reliability == "best_effort"
            else ReliabilityPolicy.RELIABLE
        ),
        durability=(
            DurabilityPolicy.TRANSIENT_LOCAL
            if qos.durability == "transient_local"
            else DurabilityPolicy.VOLATILE
        ),
        liveliness=(
            LivelinessPolicy.MANUAL_BY_TOPIC
            if qos.liveliness == "manual_by_topic"
            else LivelinessPolicy.AUTOMATIC
        ),
    )
    for key in ("deadline", "lifespan", "liveliness_lease"):
        value = getattr(qos, key)
        if value is not None:
            name = "liveliness_lease_duration" if key == "liveliness_lease" else key
            setattr(profile, name, Duration(nanoseconds=int(value * 1_000_000_000)))
    return profile


def with_time_parameters(node: Node, spec: ir.Spec) -> ir.Spec:
    """The spec with each topic's time source as the `time.<name>` parameter says."""

    def parameter(name: str, default: str) -> str:
        return str(node.declare_parameter(name, default).value)

    return with_time_sources(spec, parameter, node.get_name())


def subscribe(
    node: Node, spec: ir.Spec, callback: Callable[[str, Any, dict[str, Any]], None]
) -> dict[str, str]:
    """A subscription to every topic of the spec with its QoS; `callback(topic,
    message, info)` names the topic as the spec does. The parameter
    `topics.<name>` holds the ROS name to read (a topic can be remapped). The ROS
    names read, with their types."""
    read = {}
    variables: dict[str, list[ir.Variable]] = {}  # by topic, found once for all
    for variable in spec.variables:
        variables.setdefault(variable.topic, []).append(variable)
    for topic in spec.topics:
        ros_name = node.declare_parameter(f"topics.{topic.name}", topic.ros_name).value
        read[ros_name] = topic.message_type
        unread = ros2_definitions.unread(topic, variables.get(topic.name, []))
        node.create_subscription(
            ros2_definitions.class_of(topic.message_type),
            ros_name,
            functools.partial(_received, callback, topic.ros_name, unread),
            qos_profile(topic.qos),
        )
    return read


def _received(
    callback: Callable[[str, Any, dict[str, Any]], None],
    topic: str,
    unread: dict[str, str],
    message: Any,
    info: Any,
) -> None:
    """A message of `topic`, with the variables its installed class does not give
    (monitor.Monitor.feed skips them, as the replay does)."""
    if unread:
        info = {**info, "unread": unread}
    callback(topic, message, info)


def log_at(node: Node, level: str, text: str) -> None:
    """Log at a level named at run time, safe for a terminal (the names in a line
    are the graph's and the recordings'). Each severity has its own call: rclpy's
    logger remembers a call site's severity and refuses another one there."""
    logger, text = node.get_logger(), visible(text)
    if level == "debug":
        logger.debug(text)
    elif level == "info":
        logger.info(text)
    elif level == "warn":
        logger.warning(text)
    elif level == "error":
        logger.error(text)
    else:
        logger.fatal(text)


def diagnostics(node: Node, statuses: list[Status]) -> DiagnosticArray:
    array = DiagnosticArray()
    array.header.stamp = node.get_clock().now().to_msg()
    classes = (DiagnosticStatus, KeyValue)
    filled: DiagnosticArray = fill_diagnostics(array, statuses, classes, LEVELS, package())
    return filled


def node_actions(node: Node, spec: ir.Spec) -> NodeActions:
    """The actions as `node` takes them. Every `publish` topic's publisher is made
    at start-up: one made at the first alert would publish it before any
    subscriber had matched."""
    publishers = {
        topic: node.create_publisher(String, topic, ACTION_QOS)
        for topic in ir.published_topics(spec)
    }

    def log(level: str, text: str) -> None:
        log_at(node, level, text)

    def publish(topic: str, text: str) -> None:
        if topic not in publishers:  # not in the spec given at start-up: made now
            publishers[topic] = node.create_publisher(String, topic, ACTION_QOS)
        publishers[topic].publish(String(data=text))

    return NodeActions(log, publish)


class MonitorNode(Node):
    """The spec's topics in, verdict segments on /rmv/verdicts, a DiagnosticArray on
    /diagnostics, the actions: monitor.Monitor does the work."""

    def __init__(self, spec: ir.Spec) -> None:
        super().__init__(monitor.NODE_NAME)
        param = self.declare_parameter
        verdict_topic = param("verdict_topic", "/rmv/verdicts").value
        self.verdicts = self.create_publisher(String, verdict_topic, 100)
        self.diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        spec = with_time_parameters(self, spec)
        self.monitor = monitor.Monitor(
            spec, node_actions(self, spec), self, lambda: self.get_clock().now().nanoseconds,
            decide_period=float(param("decide_period", 0.1).value),
            diagnostics_period=float(param("diagnostics_period", 1.0).value),
            queue_depth=int(param("queue_depth", 100_000).value),
        )  # fmt: skip
        self.types = TypeWatch(monitor.NODE_NAME, subscribe(self, spec, self.monitor.take))
        self.monitor.start()

    # monitor.Outputs
    def verdict(self, text: str) -> None:
        self.verdicts.publish(String(data=text))

    def statuses(self, statuses: list[Status]) -> None:
        publishers = [
            (topic, _full_name(info.node_namespace, info.node_name), info.topic_type)
            for topic in self.types.expected
            for info in self.get_publishers_info_by_topic(topic)
        ]
        status, warnings = self.types.look(publishers)
        for text in warnings:
            self.warn(text)
        self.diagnostics.publish(diagnostics(self, [*statuses, status]))

    def warn(self, text: str) -> None:
        log_at(self, "warn", text)


def _full_name(namespace: str, name: str) -> str:
    return f"{namespace.rstrip('/')}/{name}"


class IntrusionNode(Node):
    """Reads the ROS graph every `poll` (a steady clock: the graph changes in real
    time, simulated or not) and reports what intrusion.IntrusionWatch finds."""

    def __init__(self, spec: ir.Spec) -> None:
        super().__init__(intrusion.NODE_NAME)
        poll = float(self.declare_parameter("poll", float(spec.intrusion.poll)).value)
        own = (self.get_fully_qualified_name(), "/" + monitor.NODE_NAME)
        self.watch = intrusion.IntrusionWatch(spec, node_actions(self, spec), own)
        self.diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_timer(poll, self.poll, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def seen(self) -> list[intrusion.Seen]:
        found = []
        for topic, _ in self.get_topic_names_and_types():
            for role, infos in (
                ("publisher", self.get_publishers_info_by_topic(topic)),
                ("subscriber", self.get_subscriptions_info_by_topic(topic)),
            ):
                found += [
                    intrusion.Seen(topic, role, info.node_namespace, info.node_name,
                                   bytes(info.endpoint_gid))
                    for info in infos
                ]  # fmt: skip
        return found

    def poll(self) -> None:
        now = self.get_clock().now().nanoseconds
        for level, text in self.watch.poll(now, self.seen(), time.monotonic()):
            log_at(self, level, text)
        self.diagnostics.publish(diagnostics(self, [self.watch.status()]))


class CollectorNode(Node):
    """The spec's topics into InfluxDB: collector.Collector does the work; the
    spec's `database` block gives the defaults of the parameters."""

    def __init__(self, spec: ir.Spec) -> None:
        super().__init__(collector.NODE_NAME)
        database = spec.database
        assert database is not None  # the kapacitor target builds no collector without
        param = self.declare_parameter
        settings = collector.settings(database, lambda name, default: param(name, default).value)
        period = float(param("diagnostics_period", 1.0).value)
        spec = with_time_parameters(self, spec)
        self.collector = collector.Collector(
            spec, settings, self, lambda: self.get_clock().now().nanoseconds
        )
        self.diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        subscribe(self, spec, self.collector.take)
        self.create_timer(period, self.tick)
        self.collector.start()

    # collector.Logs
    def log(self, level: str, text: str) -> None:
        log_at(self, level, text)

    def tick(self) -> None:
        self.diagnostics.publish(diagnostics(self, [self.collector.tick()]))

    def finish(self) -> None:
        self.diagnostics.publish(diagnostics(self, [self.collector.finish()]))


def run(make: Callable[[ir.Spec], Node], finish: Callable[[Any], None] | None = None) -> None:
    """Spin a node until SIGINT or SIGTERM, then let it finish and destroy it."""
    use_discovery_profile(os.environ)
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = make(load_spec())
    stop = threading.Event()
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: stop.set())
    try:
        while not stop.is_set() and rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.05)
        if finish is not None:
            finish(node)
            for _ in range(10):  # let the last messages leave
                rclpy.spin_once(node, timeout_sec=0.02)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def monitor_main() -> None:
    run(MonitorNode, lambda node: node.monitor.finish())


def intrusion_main() -> None:
    run(IntrusionNode)


def collector_main() -> None:
    run(CollectorNode, lambda node: node.finish())
