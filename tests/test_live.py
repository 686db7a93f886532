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
