"""Live hosts (issue 31): what a monitor beside a running robot must do that a
replay of a finished recording need not. Runtime-level tests here; the ROS 2 node
end to end in tests/test_ros2.py."""

from __future__ import annotations

from pathlib import Path

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime import engine

NS = 10**9
OVERSPEED = """system over
ros humble
topic a: std_msgs/Float64 = "/a"
var V = a.data
event Overspeed when V > 10
property NoLongOverspeed: duration[2s](Overspeed) < 1s {
    action log("over speed for a second of two")
}
"""


def _runtime(tmp_path: Path, text: str) -> engine.Runtime:
    path = tmp_path / "spec.rmv"
    path.write_text(text, encoding="utf-8")
    return engine.Runtime(lower(check(str(path), use_environment=False)))


def test_a_violation_that_lasts_is_decided_while_it_lasts(tmp_path):
    """Over speed from 2 s, no message after: by 3 s the robot has been over speed
    for 1 s of the 2 s window from 1 s, so the property is false from 1 s on. A live
    host's clock passing 3 s decides it, with no message (it waited for SIGINT)."""
    runtime = _runtime(tmp_path, OVERSPEED)
    runtime.message(1 * NS, "/a", {"data": 5.0})
    runtime.message(2 * NS, "/a", {"data": 20.0})
    runtime.decide(complete_before=3 * NS - 1)
    assert runtime.pending_segments == {}
    assert not [r for r in runtime.records() if r["kind"] in ("verdict", "action")]
    runtime.decide(complete_before=3 * NS)
    assert runtime.pending_segments["NoLongOverspeed"][4] == "false"
    assert runtime.pending_segments["NoLongOverspeed"][0] == 1
    actions = [r for r in runtime.records() if r["kind"] == "action"]
    assert [a["message"] for a in actions] == ["over speed for a second of two"]
    assert runtime.counters["violations: NoLongOverspeed"] == 1


def test_deciding_early_changes_nothing_in_the_result(tmp_path):
    """The same messages with and without a live clock: the same records."""

    def records(live: bool) -> list:
        runtime = _runtime(tmp_path, OVERSPEED)
        out = []
        for k, speed in enumerate([5.0, 20.0, 20.0, 5.0, 30.0, 5.0]):
            runtime.message(NS + k * 7 * NS // 10, "/a", {"data": speed})
            if live:
                for step in range(1, 7):
                    runtime.decide(complete_before=NS + k * 7 * NS // 10 + step * NS // 10)
            out.extend(runtime.records())
        runtime.end(6 * NS)
        return sorted(map(engine.to_json, out + runtime.records()))

    assert records(live=True) == records(live=False)


BRIDGE = """system bridge
ros noetic
topic odom: nav_msgs/Odometry = "/odom"
var X = odom.pose.pose.position.x
event Far when X > 100
property Near: not Far
node "/bridge" {
    publishes: "/odom"
}
whitelist odom {
    publishers: "/bridge"
}
intrusion {
    default = deny
    action publish("/rmv/intrusion")
}
"""


def _intrusions(runtime: engine.Runtime, endpoints: list[engine.Endpoint]) -> list[dict]:
    runtime.message(NS, "/odom", {"pose": {"pose": {"position": {"x": 1.0}}}})
    runtime.graph(NS, endpoints)
    return [r for r in runtime.records() if r["kind"] == "intrusion"]


def test_what_ros_has_every_node_do_is_no_intrusion(tmp_path):
    """The spec's own bridge, on ROS 2, publishes /parameter_events and /rosout and
    listens to /parameter_events and /clock, as every ROS 2 node does: it was
    reported about a second after it started, every run. A rogue publisher on
    /odom still is, and its record says who once."""
    endpoints = [
        engine.Endpoint("/bridge", "/odom", "publisher"),
        engine.Endpoint("/bridge", "/parameter_events", "publisher"),
        engine.Endpoint("/bridge", "/rosout", "publisher"),
        engine.Endpoint("/bridge", "/parameter_events", "subscriber"),
        engine.Endpoint("/bridge", "/clock", "subscriber"),
        engine.Endpoint("/rogue", "/odom", "publisher"),
    ]
    path = tmp_path / "spec.rmv"
    path.write_text(BRIDGE, encoding="utf-8")
    spec = lower(check(str(path), use_environment=False))
    found = _intrusions(engine.Runtime(spec, ros_version=2), endpoints)
    assert [(r["node"], r["topic"], r["reason"]) for r in found] == [
        ("/rogue", "/odom", "not in the publishers allowed on /odom")
    ]
    # ROS 1 has no /parameter_events: there it is an intrusion.
    found = _intrusions(engine.Runtime(spec, ros_version=1), endpoints)
    assert ("/bridge", "/parameter_events") in {(r["node"], r["topic"]) for r in found}
    # `infrastructure = none` removes the exception; a `node` rule then says why,
    # naming the node once.
    strict = BRIDGE.replace("default = deny", "infrastructure = none")
    path.write_text(strict, encoding="utf-8")
    found = _intrusions(
        engine.Runtime(lower(check(str(path), use_environment=False)), ros_version=2),
        endpoints,
    )
    reasons = {(r["node"], r["topic"]): r["reason"] for r in found}
    assert reasons[("/bridge", "/rosout")] == "may not publish on /rosout"


STAMPED = """system stamped
ros humble
topic a: geometry_msgs/TwistStamped = "/a" qos { time = header }
topic b: geometry_msgs/TwistStamped = "/b" qos { time = header }
topic c: geometry_msgs/TwistStamped = "/c"
var A = a.twist.linear.x
var B = b.twist.linear.x
var C = c.twist.linear.x
event Both when A > 1 and B > 1
event Apart when A > 1 and C > 1
transducer T {
    states Idle, Busy
    initial Idle
    Idle -> Busy on Both
    Busy -> Idle on Apart
}
property P1: not Busy
property P2: not Apart
property P3: not Busy { lateness = 100ms }
"""


def test_stamped_topics_feeding_one_property_need_a_lateness(tmp_path):
    """P1 reads /a and /b through the transducer, both timed by their stamps, with
    no `lateness`: RMV224. P2 reads one stamped topic; P3 has a lateness."""
    path = tmp_path / "spec.rmv"
    path.write_text(STAMPED, encoding="utf-8")
    found = [d for d in check(str(path), use_environment=False).diagnostics if d.code == "RMV224"]
    assert [d.message for d in found] == [
        "property `P1` reads 2 topics timed by their header stamps (`a`, `b`) and has no `lateness`"
    ]
