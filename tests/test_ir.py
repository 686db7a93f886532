"""The resolved spec (rmvdsl.ir, rmvdsl.runtime.spec): every example lowers, its
JSON is golden, the JSON round-trips exactly, every default comes from the
registry, and malformed JSON is refused with a reason.

Regenerate the golden files with `UPDATE_GOLDEN=1 pytest tests/test_ir.py`; in
that mode the golden test cannot fail, so `git diff tests/golden/ir` is reviewed
line by line. `test_hand_checked_values` never regenerates: its values were worked
out by hand from the specs, InfluxDB's documentation and the ROS definitions.
"""

from __future__ import annotations

import json
import os
from fractions import Fraction
from pathlib import Path

import pytest
from conftest import EXAMPLES, ROOT

from rmvdsl.check import check
from rmvdsl.ir import LowerError, lower
from rmvdsl.lang import builtins
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.spec import FormatError, dump, load
from rmvdsl.util.deep import deep

GOLDEN = Path(__file__).parent / "golden" / "ir"
GOOD = ["carla/abs.rmv", "gazebo/prius_platoon.rmv", "gazebo/network.rmv"]


def _lowered(relative: str, monkeypatch: pytest.MonkeyPatch) -> ir.Spec:
    monkeypatch.chdir(ROOT)
    return lower(check(f"examples/{relative}"))


@pytest.mark.parametrize("relative", GOOD)
def test_every_example_lowers_to_its_golden_json(relative, monkeypatch):
    text = dump(_lowered(relative, monkeypatch)) + "\n"
    golden = GOLDEN / (Path(relative).stem + ".json")
    if os.environ.get("UPDATE_GOLDEN"):
        golden.parent.mkdir(parents=True, exist_ok=True)
        golden.write_text(text, encoding="utf-8")
    assert text == golden.read_text(encoding="utf-8")


@pytest.mark.parametrize("relative", GOOD)
def test_the_json_round_trips_exactly(relative, monkeypatch):
    spec = _lowered(relative, monkeypatch)
    text = dump(spec)
    again = load(text)
    assert again == spec
    assert dump(again) == text


def test_rmv_build_prints_the_golden_json(rmv):
    result = rmv("build", "--target", "ir", "examples/carla/abs.rmv")
    assert result.code == 0, result.err
    assert result.out == (GOLDEN / "abs.json").read_text(encoding="utf-8")


def test_rmv_build_refuses_a_spec_with_errors(rmv, tmp_path):
    out = tmp_path / "out.json"
    result = rmv("build", "--target", "ir", "examples/errors/undefined.rmv", "-o", str(out))
    assert result.code == 1
    assert "error[RMV200]" in result.err and "nothing built" in result.err
    assert not out.exists()
    with pytest.raises(LowerError):
        lower(check(str(EXAMPLES / "errors" / "undefined.rmv")))


def test_hand_checked_values(monkeypatch):
    """Worked out by hand from examples/carla/abs.rmv."""
    spec = _lowered("carla/abs.rmv", monkeypatch)
    events = {e.name: e for e in spec.events}
    kmh = events["EVelocityinKMH"]
    # group by time(100ms); resample every 1m without `for`: InfluxDB's querier then
    # reads the EVERY interval (60 s), not the group-by interval.
    assert kmh.window == ir.Window(Fraction(1, 10), Fraction(0))
    assert (kmh.resample_every, kmh.resample_for, kmh.range) == (60, 60, 1)
    assert kmh.fill == ir.Fill("null") and kmh.order == "asc" and kmh.limit is None
    assert events["ObjectsNearby"].fill == ir.Fill("previous")
    # Events come after what they read; boolean events read value events.
    order = [e.name for e in spec.events]
    assert order.index("EderivativeVelocity") < order.index("HardBrake")
    assert order.index("ObjectsNearby") > 0 or events["ObjectsNearby"].reads == ("FastestObject",)
    derivative = events["EderivativeVelocity"]
    assert derivative.type == ir.ValueType("float", "float32", -1)  # m/s per second
    assert isinstance(derivative.expr, ir.Call) and derivative.expr.function == "derivative"
    # FastestObject = max(objects.objects[*].twist.linear.x)
    fastest = next(v for v in spec.variables if v.name == "FastestObject")
    assert [type(s).__name__ for s in fastest.path] == [
        "FieldStep", "EachStep", "FieldStep", "FieldStep", "FieldStep",
    ]  # fmt: skip
    assert fastest.aggregate == "max" and fastest.type.ros == "float64"
    # Formula 3.1: 10 s ahead; its window 10 s as written; rate 10 Hz.
    check31 = next(p for p in spec.properties if p.name == "ABSCheck")
    assert (check31.horizon_future, check31.horizon_past, check31.window) == (10, 0, 10)
    assert check31.rate == 10 and check31.trigger == "always" and check31.lateness == 0
    assert check31.actions[0] == ir.Log(
        "ABSCheck violated: hard braking did not end in a stop", "error"
    )
    assert check31.actions[1] == ir.Publish("/rmv/alerts", None)
    stops = next(p for p in spec.properties if p.name == "StopsAfterHardBrake")
    assert stops.horizon_future == 75 and stops.propositions == ("HardBraking", "StopReached")
    # The database: `raw` is the default policy, 1d = 86400 s; the downsample reads it.
    assert spec.database is not None
    assert spec.database.default_retention == "raw"
    assert spec.database.retentions[0].duration == 86400
    assert spec.database.downsamples[0].source == "raw"
    assert spec.database.password == ir.Credential(env="RMV_INFLUX_PASSWORD")
    assert spec.database.url == "http://127.0.0.1:8086"
    # The transducer: StopReached is emitted on two transitions, listed once.
    braking = spec.transducers[0]
    assert braking.emits == ("StopReached",) and len(braking.transitions) == 7
    # Whitelist patterns: `*` is any run of characters, everything else literal.
    status = spec.whitelists[0]
    assert status.topic_name == "vehicle_status"
    assert [p.regex for p in status.subscribers or ()] == [
        r"^/rmv_monitor$", r"^/rviz.*$", r"^/rostopic_.*$",
    ]  # fmt: skip
    assert spec.intrusion.poll == 1 and spec.intrusion.default == "allow"


_MINIMAL = """system m
ros humble
topic imu: sensor_msgs/msg/Imu = "/imu"
var Z = imu.linear_acceleration.z
event Up when Z > 0
event Late = mean(Z) group by time(1s)
event Early when Late > 1
transducer T {
    states A, B
    initial A
    A -> B on Up
    B -> A on Early
}
property P: eventually[<=2s] B
alert Hi {
    crit when Z > 20
    action post("http://127.0.0.1:9/x")
    action exec("/bin/notify", ["-u", "critical"])
}
whitelist imu {
    publishers: "/driver"
}
"""


def _minimal(tmp_path: Path, text: str = _MINIMAL) -> ir.Spec:
    path = tmp_path / "m.rmv"
    path.write_text(text, encoding="utf-8")
    result = check(str(path))
    assert not result.errors, [d.message for d in result.errors]
    return lower(result)


def test_every_default_comes_from_the_registry(tmp_path):
    spec = _minimal(tmp_path)
    topic = spec.topics[0]
    for key, setting in builtins.block("qos").settings.items():
        # `time` is the topic's time source, `max_rate` its declared rate; the rest
        # are ROS 2 QoS settings
        own = {"time": topic.time_source, "max_rate": topic.max_rate}
        value = own[key] if key in own else getattr(topic.qos, key)
        assert value == setting.default, key
    prop = spec.properties[0]
    assert prop.rate is builtins.setting("property", "rate").default is None
    assert prop.trigger == builtins.setting("property", "trigger").default == "always"
    assert prop.lateness == builtins.setting("property", "lateness").default == 0
    assert prop.window == prop.horizon_future == 2  # `window` defaults to the horizon
    alert = spec.alerts[0]
    assert alert.id == "Hi" and alert.message == "Hi"  # derived: the alert's name
    assert alert.details == builtins.setting("alert", "details").default
    assert alert.actions == (
        ir.Post("http://127.0.0.1:9/x", builtins.action("post").parameters["timeout"].default),
        ir.Exec("/bin/notify", ("-u", "critical")),
    )
    intrusion = spec.intrusion
    assert (intrusion.poll, intrusion.default, intrusion.ignore_nodes) == (1, "allow", ())
    assert intrusion.origin == ""  # no `intrusion` block: all defaults


def test_events_are_ordered_by_what_they_read(tmp_path):
    order = [e.name for e in _minimal(tmp_path).events]
    assert order.index("Late") < order.index("Early")


def test_ros1_time_fields_are_mapped_to_what_decoding_gives(tmp_path):
    text = """system t
ros noetic
topic imu: sensor_msgs/Imu = "/imu"
var Secs = imu.header.stamp.secs
event Old when Secs < 5
transducer T {
    states A, B
    initial A
    A -> B on Old
}
property P: eventually[<=1s] B
"""
    spec = _minimal(tmp_path, text)
    steps = spec.variables[0].path
    assert steps[-1] == ir.FieldStep("secs", "sec", "uint32")
    assert spec.ros == ir.Ros("noetic", 1)


def test_a_deep_expression_lowers_and_round_trips(tmp_path):
    """20,000 operands (20 times the default recursion limit): lowering, printing
    and reading never run out of stack."""
    text = _MINIMAL + "event Sum when " + " + ".join(["Z"] * 20_000) + " > 3\n"
    spec = deep(_minimal, tmp_path, text)
    dumped = deep(dump, spec)
    assert deep(lambda: load(dumped) == spec)  # deep equality needs the deep stack too
    assert len(dumped) < 400 * 20_000  # linear: no indentation grows with the depth


@pytest.mark.parametrize(
    ("mutate", "reason"),
    [
        (lambda d: d.update(version=2), "version 2"),
        (lambda d: d.update(format="other"), "not a resolved spec"),
        (lambda d: d["topics"][0].update(extra=1), "unknown keys in Topic"),
        (lambda d: d["topics"][0].pop("qos"), "has no `qos`"),
        (lambda d: d["topics"][0]["qos"].update(depth="ten"), "expected an integer"),
        (lambda d: d["properties"][0].update(formula=["nope"]), "not a formula node"),
        (lambda d: d["events"][0].update(expr={"node": "bogus"}), "expected a node"),
        (lambda d: d["events"][0].update(expr={"node": "log"}), "cannot stand here"),
        (lambda d: d["properties"][0].update(window="1/0"), "malformed"),
    ],
)
def test_malformed_json_is_refused_with_a_reason(tmp_path, mutate, reason):
    payload = json.loads(dump(_minimal(tmp_path)))
    mutate(payload)
    with pytest.raises(FormatError, match=reason):
        load(json.dumps(payload))


def test_non_decimal_numbers_stay_exact(tmp_path):
    text = _MINIMAL.replace(
        "property P: eventually[<=2s] B",
        "property P: eventually[<=2s] B {\n    rate = 3Hz\n    window = 7s\n}",
    )
    spec = _minimal(tmp_path, text)
    assert spec.properties[0].rate == 3
    thirds = ir.Window(Fraction(1, 3), Fraction(0))
    event = spec.events[0]
    import dataclasses

    changed = dataclasses.replace(spec, events=(dataclasses.replace(event, window=thirds),))
    text_out = dump(changed)
    assert '"1/3"' in text_out
    assert load(text_out) == changed
