"""`rmv build --target ros2` on real ROS 2 (the PyPI wheels), inside a private
network namespace holding only loopback: nothing can leave the machine."""

from __future__ import annotations

import base64
import functools
import itertools
import json
import os
import random
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from conftest import ROOT, assert_soaked, per_property
from fleet_recordings import sent_bag

from rmvdsl.check import check
from rmvdsl.host.monitor import BATCH
from rmvdsl.ir import lower
from rmvdsl.targets import kapacitor, ros2

sys.path.insert(0, str(Path(__file__).resolve().parent / "ros2"))
import rosenv

HERE = Path(__file__).resolve().parent / "ros2"
CARLA = ROOT / "examples" / "carla"

START = 1_700_000_000 * 10**9
SPEC = """system std_braking "braking, in standard ROS 2 types"
time unit s
topic twist: geometry_msgs/msg/TwistStamped = "/vehicle/twist" qos {
    depth = 1000
    durability = transient_local
    time = header
}
var Speed = twist.twist.linear.x
event Fast when Speed > 25
event Stopped when Speed < 0.1
/// Fast for less than 2 s of every 4 s.
property NotFastLong: duration[4s](Fast) < 2s
property NeverStops: not Stopped
whitelist twist {
    publishers: "/player"
}
intrusion {
    poll = 200ms
    action publish("/rmv/intrusion")
}
"""
TWIST = "geometry_msgs/msg/TwistStamped"
# A violation that lasts with no message while it does (issue 31): decided when
# time passes, its alert published to subscribers that come later.
OVERSPEED = """system overspeed "a robot over speed for long"
topic twist: geometry_msgs/msg/TwistStamped = "/vehicle/twist"
var Speed = twist.twist.linear.x
event Overspeed when Speed > 25
property NoLongOverspeed: duration[2s](Overspeed) < 1s {
    action publish("/rmv/alerts")
    action log("over speed for too long", level = warn)
    action log("stop the robot", level = error)
}
whitelist twist {
    publishers: "/player"
}
intrusion {
    poll = 200ms
    action publish("/rmv/intrusion")
}
"""
# Two topics timed by their stamps and no lateness (RMV224 warns): a stamp older
# than one already fed is dropped, and the property is unknown where it reads it.
STAMPED = """system stamped "two topics timed by their stamps"
topic left: geometry_msgs/msg/TwistStamped = "/left" qos {
    depth = 1000
    durability = transient_local
    time = header
}
topic right: geometry_msgs/msg/TwistStamped = "/right" qos {
    depth = 1000
    durability = transient_local
    time = header
}
var Left = left.twist.linear.x
var Right = right.twist.linear.x
event Apart when Left - Right > 5 or Right - Left > 5
property Together: not Apart
"""
# A reader that keeps one message: a burst overflows it.
LOSSY = """system lossy "a topic read with depth 1"
time unit s
topic twist: geometry_msgs/msg/TwistStamped = "/vehicle/twist" qos {
    depth = 1
}
var Speed = twist.twist.linear.x
event Stopped when Speed < 0.1
property NeverStops: not Stopped
"""

# std_braking's, its topic declared at 20 Hz: a flood is counted past it.
FLOOD = SPEC.replace("system std_braking", "system flood").replace(
    "    time = header\n", "    time = header\n    max_rate = 20Hz\n", 1
)

# The kapacitor target's collector: std_braking's topic and variable, into InfluxDB.
COLLECTED = """system collected "the twist topic, stored in InfluxDB"
database {
    name = "collected"
    batch_size = 20
    flush_interval = 100ms
}
topic twist: geometry_msgs/msg/TwistStamped = "/vehicle/twist" qos {
    depth = 1000
    durability = transient_local
    time = header
}
var Speed = twist.twist.linear.x
event MeanSpeed = mean(Speed) group by time(1s)
event Fast when Speed > 50
transducer Motion {
    states Slow, Quick
    initial Slow
    Slow -> Quick on Fast
}
"""


def _speed(k: int) -> float:
    """20 m/s, then 30 m/s for 3 s from 2 s, braking to a stop at 8 s."""
    if k < 40:
        return 20.0
    if k < 100:
        return 30.0
    return max(0.0, 30.0 - (k - 100) * 0.5)


MESSAGES = [(START + k * 50_000_000, _speed(k)) for k in range(200)]


def _carla_spec() -> str:
    """examples/carla/abs.rmv with times from header stamps, and readers that keep
    what was sent before they matched (discovery is not symmetric: the player may
    see the node's reader before the reader sees the player). The lateness covers
    the whole recording (28 s of stamps): the player sends it at about ten times its
    speed, so a reader matching 0.1 s after the other gets its topic's backlog a
    second of stamps late; 1 s of lateness made that a late drop (unknown verdicts)
    in about one run of six on a loaded machine."""
    text = (CARLA / "abs.rmv").read_text(encoding="utf-8")
    text = text.replace('messages "msg"', f"messages {json.dumps(str(CARLA / 'msg'))}")
    qos = "    depth = 1000\n    durability = transient_local\n    time = header\n"
    text = text.replace("    depth = 10\n    reliability = reliable\n", qos)
    objects = '"/carla/hero/objects"\n'
    text = text.replace(objects, f"{objects[:-1]} qos {{\n{qos}}}\n")
    assert text.count("transient_local") == 2
    return text.replace("    trigger = always\n", "    trigger = always\n    lateness = 30s\n")


def _checked(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    result = check(str(path))
    assert not result.errors, [str(d) for d in result.errors]
    return path


@pytest.fixture(scope="module")
def specs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("specs")
    return {
        "std_braking": _checked(folder / "std_braking.rmv", SPEC),
        "carla_abs": _checked(folder / "carla_abs.rmv", _carla_spec()),
        "lossy": _checked(folder / "lossy.rmv", LOSSY),
        "flood": _checked(folder / "flood.rmv", FLOOD),
        "collected": _checked(folder / "collected.rmv", COLLECTED),
        "overspeed": _checked(folder / "overspeed.rmv", OVERSPEED),
        "stamped": _checked(folder / "stamped.rmv", STAMPED),
        "soak": _checked(folder / "soak.rmv", (HERE / "soak.rmv").read_text(encoding="utf-8")),
    }


@pytest.fixture(scope="module")
def workspace(specs, tmp_path_factory) -> Path:
    """A colcon workspace holding the generated packages and the CARLA message
    packages (from examples/carla/msg), built with `colcon build` as a user would."""
    python = rosenv.python()
    assert python
    root = tmp_path_factory.mktemp("ws")
    src = root / "src"
    for name, path in specs.items():
        resolved = lower(check(str(path)))
        if name == "collected":  # the kapacitor target's collector
            build = kapacitor.plan(resolved, root / "handlers")
            ros2.write(kapacitor.collector_files(build), src / f"{name}_kapacitor")
        else:
            ros2.build(resolved, src / name)
    # The messages abs.rmv reads and what they nest (4 of 25: the build is the
    # slowest step of the suite).
    rosenv.message_package(src, CARLA / "msg" / "carla_msgs", ["std_msgs", "geometry_msgs"],
                           only=["CarlaEgoVehicleStatus"])  # fmt: skip
    rosenv.message_package(
        src,
        CARLA / "msg" / "derived_object_msgs",
        ["std_msgs", "geometry_msgs", "shape_msgs"],
        only=["ObjectArray"],
    )
    built = rosenv.colcon_build(root)
    assert built.returncode == 0, (built.stdout + built.stderr)[-6000:]
    return root


def _executable(workspace: Path, package: str, name: str) -> str:
    """A node's console script, where colcon installed it (what `ros2 run` starts)."""
    path = workspace / "install" / package / "lib" / package / name
    assert path.exists(), f"colcon did not install {path}"
    return str(path)


def _drive(workspace: Path, scenario: dict, tmp_path: Path, domain: int) -> dict:
    file = tmp_path / "scenario.json"
    file.write_text(json.dumps(scenario), encoding="utf-8")
    run = rosenv.run(
        [rosenv.python(), str(HERE / "drive_monitor.py"), str(file)], domain, workspace
    )
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    seen = json.loads(run.stdout)
    assert seen["code"] == 0, seen["log"]
    return seen


@functools.cache
def _store() -> Any:
    """rosbags' ROS 2 type store: made once (each takes tens of milliseconds, which
    the floods' thousands of messages would pay each)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _twist_cdr(stamp: int, speed: float) -> bytes:
    store = _store()
    types = store.types
    message = types[TWIST](
        header=types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](*divmod(stamp, 10**9)), frame_id=""
        ),
        twist=types["geometry_msgs/msg/Twist"](
            linear=types["geometry_msgs/msg/Vector3"](speed, 0.0, 0.0),
            angular=types["geometry_msgs/msg/Vector3"](0.0, 0.0, 0.0),
        ),
    )
    return bytes(store.serialize_cdr(message, TWIST))


def _record(
    path: Path,
    messages: list[tuple[int, float]],
    stamps: list[int],
    topics: list[str] | None = None,
) -> None:
    """The twist messages as a ROS 2 bag, logged at `stamps` (on /vehicle/twist, or
    each on its topic of `topics`)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _store()
    topics = topics or ["/vehicle/twist"] * len(messages)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {
            topic: writer.add_connection(topic, TWIST, typestore=store)
            for topic in dict.fromkeys(topics)
        }
        for (stamp, speed), logged, topic in zip(messages, stamps, topics, strict=True):
            writer.write(connections[topic], logged, _twist_cdr(stamp, speed))


def _verdicts(replay_out: str) -> list[dict]:
    return [json.loads(line) for line in replay_out.splitlines() if '"kind": "verdict"' in line]


def _instants(verdicts: list[dict]) -> list[float]:
    """Every bound of a segment, and a time between each two."""
    bounds = sorted({float(v[k]) for v in verdicts for k in ("from", "to")})
    return sorted(bounds + [(a + b) / 2 for a, b in itertools.pairwise(bounds)])


def _read_at(verdicts: list[dict], instants: list[float]) -> list[tuple]:
    """Each property's verdict at each instant, by the last record covering it (a
    revision overrides what came before)."""
    out = []
    for name in sorted({v["property"] for v in verdicts}):
        for time in instants:
            said = None
            for v in verdicts:
                low, high = float(v["from"]), float(v["to"])
                inside = (low < time or (low == time and v["bounds"][0] == "[")) and (
                    time < high or (time == high and v["bounds"][1] == "]")
                )
                if v["property"] == name and inside:
                    said = v["verdict"]
            out.append((name, time, said))
    return out


def _publish(topic: str, data: bytes) -> list[str]:
    return ["publish", topic, base64.b64encode(data).decode("ascii")]


def test_the_node_publishes_the_replays_verdicts(specs, workspace, tmp_path, rmv):
    seen = _drive(workspace, {
        "monitor": [_executable(workspace, "std_braking", "monitor")],
        "publishers": {"/vehicle/twist": TWIST},
        "steps": [_publish("/vehicle/twist", _twist_cdr(t, v)) for t, v in MESSAGES],
    }, tmp_path, rosenv.DOMAIN)  # fmt: skip
    from_node = [json.loads(v) for v in seen["verdicts"]]

    recording = tmp_path / "twist"
    _record(recording, MESSAGES, [t for t, _ in MESSAGES])
    replay = rmv("replay", str(specs["soak"]), str(recording), "--format", "jsonl")
    assert replay.code == 1, replay.err
    from_replay = _verdicts(replay.out)
    assert len(from_replay) >= 4
    assert per_property(from_node) == per_property(from_replay)
    violated = [v for v in from_node if v["verdict"] == "false"]
    assert {v["property"] for v in violated} == {"NotFastLong", "NeverStops"}
    diagnostics = seen["diagnostics"]
    assert diagnostics["rmv_monitor: monitor"]["messages"] == "200"
    assert diagnostics["rmv_monitor: property NotFastLong"]["formula"]


def test_carla_types_the_abs_example_on_ros2(specs, workspace, tmp_path, rmv):
    """The README's CARLA recording, played as raw CDR bytes of carla_msgs and
    derived_object_msgs (built by colcon from examples/carla/msg): the node decodes
    them and its verdicts are the replay's."""
    from rosbags.highlevel import AnyReader

    recording = CARLA / "recordings" / "braking_mcap"
    steps, publishers = [], {}
    with AnyReader([recording]) as reader:
        for connection, _, data in reader.messages():
            publishers[connection.topic] = connection.msgtype
            steps.append(_publish(connection.topic, data))
    assert publishers["/carla/hero/vehicle_status"] == "carla_msgs/msg/CarlaEgoVehicleStatus"
    seen = _drive(workspace, {
        "monitor": [_executable(workspace, "carla_abs", "monitor")],
        "publishers": publishers, "steps": steps, "pace": 0.003,
    }, tmp_path, rosenv.DOMAIN + 1)  # fmt: skip
    replay = rmv("replay", str(specs["carla_abs"]), str(recording), "--format", "jsonl")
    assert replay.code == 1, replay.err
    from_replay = _verdicts(replay.out)
    assert per_property([json.loads(v) for v in seen["verdicts"]]) == per_property(from_replay)
    violated = {v["property"] for v in from_replay if v["verdict"] == "false"}
    assert violated == {"ABSCheck"}
    counters = seen["diagnostics"]["rmv_monitor: monitor"]
    assert counters["messages"] == str(len(steps))
    assert counters["violations: ABSCheck"] == "1"
    assert not [k for k in counters if "late" in k or "damaged" in k]


def test_sim_time_and_parameters_override_the_spec(specs, workspace, tmp_path, rmv):
    """`use_sim_time`: times of `receipt` topics come from /clock; `time.twist` turns
    the spec's `time = header` into receipt and `topics.twist` reads another topic.
    The stamps in the messages are 0: were they used, every verdict would start at 0."""
    moving, stopped = [(0, 20.0)] * 5, [(0, 0.0)] * 5
    clocks = (100 * 10**9, 110 * 10**9, 120 * 10**9)
    phases = list(zip(clocks, (moving, stopped, stopped[:1]), strict=True))
    command = [
        _executable(workspace, "std_braking", "monitor"), "--ros-args",
        "-p", "use_sim_time:=true", "-p", "time.twist:=receipt",
        "-p", "topics.twist:=/other/twist",
    ]  # fmt: skip
    steps: list[list] = []
    for clock, messages in phases:
        # Each phase's messages are received at its clock: the node has read them
        # all before the clock moves on (else the last are timed by the next).
        steps += [["settle"], ["clock", clock]]
        steps.extend(_publish("/other/twist", _twist_cdr(t, v)) for t, v in messages)
    seen = _drive(workspace, {
        "monitor": command, "publishers": {"/other/twist": TWIST}, "steps": steps,
    }, tmp_path, rosenv.DOMAIN + 2)  # fmt: skip
    from_node = [json.loads(v) for v in seen["verdicts"]]

    receipt = tmp_path / "receipt.rmv"
    receipt.write_text(SPEC.replace("    time = header\n", ""), encoding="utf-8")
    recording = tmp_path / "twist"
    played = [m for _, messages in phases for m in messages]
    _record(recording, played, [clock for clock, messages in phases for _ in messages])
    replay = rmv("replay", str(receipt), str(recording), "--format", "jsonl")
    assert per_property(from_node) == per_property(_verdicts(replay.out))
    never_stops = [(v["verdict"], v["from"], v["to"]) for v in from_node
                   if v["property"] == "NeverStops"]  # fmt: skip
    assert never_stops == [("true", 100, 110), ("false", 110, 120)]


def test_messages_the_reader_loses_are_counted(workspace, tmp_path):
    """1,500 messages as fast as rclpy sends them to a reader of depth 1: what the
    reader loses shows as gaps in the publisher's sequence numbers, and every
    message is either read or counted lost, with one warning in the log."""
    burst = [_publish("/vehicle/twist", _twist_cdr(START + k, 20.0)) for k in range(1500)]
    seen = _drive(workspace, {
        "monitor": [_executable(workspace, "lossy", "monitor")],
        "publishers": {"/vehicle/twist": TWIST},
        "steps": [burst[0], ["settle"], *burst[1:]], "pace": 0,
    }, tmp_path, rosenv.DOMAIN + 4)  # fmt: skip
    counters = seen["diagnostics"]["rmv_monitor: monitor"]
    lost = int(counters.get("lost messages: /vehicle/twist", "0"))
    assert lost > 0, counters
    print(f"{lost} of 1,500 lost")
    assert int(counters["messages"]) + lost == 1500
    # "1 message ... read it" or "N messages ... read them", said once
    lost = r"\d+ messages? lost before the monitor could read (it|them)"
    assert len(re.findall(lost, seen["log"])) == 1, seen["log"]


FLOOD_SIZE = 2_000


def test_a_flood_is_bounded_by_the_queues(workspace, tmp_path):
    """2,000 messages as fast as one rclpy publisher sends them (over 10 times the
    20 Hz the spec declares) into a monitor whose queue holds 500: every message is
    read or counted lost, the excess over the declared rate is counted and said
    once, the node holds no more than its queue and the batch it feeds (the peak in
    /diagnostics), keeps deciding, and its memory during the flood stays within
    20 MB of before it."""
    # 1 kHz of stamps, Fast for 50 ms of every 100: the queues are what is tested
    sent = [_publish("/vehicle/twist", _twist_cdr(START + k * 10**6, 20.0 + 10 * (k % 100 < 50)))
            for k in range(FLOOD_SIZE)]  # fmt: skip
    flood = [step for k in range(200, FLOOD_SIZE, 600) for step in (*sent[k : k + 600], ["rss"])]
    seen = _drive(workspace, {
        "monitor": [_executable(workspace, "flood", "monitor"), "--ros-args",
                    "-p", "queue_depth:=500", "-p", "diagnostics_period:=0.2"],
        "publishers": {"/vehicle/twist": TWIST},
        "steps": [*sent[:200], ["settle"], ["rss"], *flood, ["settle"], ["rss"]], "pace": 0,
    }, tmp_path, rosenv.DOMAIN + 11)  # fmt: skip
    counters = seen["diagnostics"]["rmv_monitor: monitor"]
    lost = int(counters.get("lost messages: /vehicle/twist", "0"))
    read = int(counters["messages"])
    over = int(counters["messages over max_rate: /vehicle/twist"])
    peak, bound = (int(n) for n in counters["messages held, most"].split(" of "))
    before, after = seen["rss"][0], max(seen["rss"])
    print(
        f"read {read}, lost {lost}, over the rate {over}; held at most {peak} of {bound}; "
        f"RSS {before / 1024:.1f} MB before, at most {after / 1024:.1f} MB during"
    )
    assert read + lost == FLOOD_SIZE
    # 20 a second allowed, so 9 in 10 over means at least 10 times the rate
    assert over >= 0.9 * read, (over, read)
    assert seen["log"].count("/vehicle/twist: more messages than its max_rate (20Hz") == 1
    assert bound == 500 + BATCH and 0 < peak <= bound  # the queue, and the batch being fed
    assert after - before < 20 * 1024, seen["rss"]
    assert any(json.loads(v)["property"] == "NeverStops" for v in seen["verdicts"])
    assert seen["code"] == 0


def test_hostile_traffic_is_counted_and_the_node_keeps_deciding(workspace, tmp_path):
    """Bytes no TwistStamped decodes from (cut short, random, 100 MB of noise), a
    stamp in 2038 and one in 1973, NaN and infinite speeds, trailing bytes, and a
    publisher of another type on the topic: the node keeps running and deciding,
    counts each kind in /diagnostics, and its verdicts are unknown only where input
    was lost."""
    good = [_twist_cdr(START + k * 10**8, 20.0) for k in range(12)]
    imposter = "std_msgs/msg/String from /imposter on /vehicle/twist"
    future = good[3][:4] + (2**31 - 1).to_bytes(4, "little") + good[3][8:]
    past = good[4][:4] + (117_835_012).to_bytes(4, "little") + good[4][8:]
    hostile = [good[1][:10], bytes(range(64)), future, past,
               _twist_cdr(START + 5 * 10**8, float("nan")),
               _twist_cdr(START + 6 * 10**8, float("inf")), good[7] + b"\x00" * 1000,
               bytes(random.Random(3).getrandbits(8) for _ in range(4096)) * 25_600]  # fmt: skip
    seen = _drive(workspace, {
        "monitor": [_executable(workspace, "std_braking", "monitor"), "--ros-args",
                    "-p", "diagnostics_period:=0.2"],
        "publishers": {"/vehicle/twist": TWIST},
        "steps": [_publish("/vehicle/twist", good[0]), ["settle"],
                  # all but the 100 MB, read or counted before it is sent: Fast DDS
                  # sends a large message on a flow of its own, and order across
                  # flows is not kept
                  *[_publish("/vehicle/twist", data) for data in hostile[:-1]], ["settle"],
                  _publish("/vehicle/twist", hostile[-1]),
                  *[_publish("/vehicle/twist", data) for data in good[8:]], ["settle"],
                  ["intruder", "imposter", "/vehicle/twist"],
                  ["status", "rmv_monitor: topic types", imposter, 15.0]],
    }, tmp_path, rosenv.DOMAIN + 8)  # fmt: skip
    # A publisher of another type, whose messages DDS never delivers: in /diagnostics
    # and the log, once.
    assert seen["waits"][-1][2] is not None, seen["diagnostics"].get("rmv_monitor: topic types")
    told = "/vehicle/twist: std_msgs/msg/String published by /imposter, the spec reads "
    assert seen["log"].count(told) == 1, seen["log"]
    counters = seen["diagnostics"]["rmv_monitor: monitor"]
    # Cut short, the 64 bytes (a string length of 252 MB) and the 100 MB do not decode:
    # rclpy drops them, and the node counts them from the gaps in the sequence.
    assert counters["lost messages: /vehicle/twist"] == "3", counters
    assert counters["messages stamped ahead dropped: /vehicle/twist"] == "1"  # 2038
    assert counters["late messages dropped: /vehicle/twist"] == "1"  # 1973
    assert int(counters["messages"]) + 3 == 1 + len(hostile) + 4
    verdicts = [json.loads(v) for v in seen["verdicts"]]
    stops = [(v["verdict"], float(v["from"]) - START / 1e9, float(v["to"]) - START / 1e9)
             for v in verdicts if v["property"] == "NeverStops"]  # fmt: skip
    # Unknown from the first message to the NaN at 0.5 s (what came between was
    # dropped: its times are not known), and from 0.7 s to 0.8 s (the 100 MB between);
    # NaN and infinity are speeds, not stops.
    assert [(v, round(a, 3), round(b, 3)) for v, a, b in stops] == [
        ("unknown", 0, 0.5), ("true", 0.5, 0.7), ("unknown", 0.7, 0.8), ("true", 0.8, 1.1)
    ]  # fmt: skip
    assert seen["code"] == 0


def test_intruders_are_reported_within_two_seconds(workspace, tmp_path):
    """A rogue ROS node and a DDS writer that is no ROS node publish on a topic whose
    whitelist allows only /player: each is reported within 2 s; /player never is;
    both leave the diagnostics when they leave the graph."""
    scenario = {
        "intrusion_node": [_executable(workspace, "std_braking", "intrusion")],
        "topic": "/vehicle/twist", "intrusions": "/rmv/intrusion", "allowed_for": 2.0,
    }  # fmt: skip
    file = tmp_path / "scenario.json"
    file.write_text(json.dumps(scenario), encoding="utf-8")
    run = rosenv.run(
        [rosenv.python(), str(HERE / "drive_intrusion.py"), str(file)],
        rosenv.DOMAIN + 3, workspace,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    seen = json.loads(run.stdout)
    assert seen["allowed_reports"] == []
    assert not [r for r in seen["reports"] if "/player" in r]
    assert set(seen["latencies"]) == {"/rogue", "_CREATED_BY_BARE_DDS_APP_"}
    assert all(latency < 2.0 for latency in seen["latencies"].values()), seen["latencies"]
    present = seen["while_present"]["values"]
    assert sorted(present) == [
        "/rogue publisher /vehicle/twist",
        "_CREATED_BY_BARE_DDS_APP_ publisher /vehicle/twist",
    ]
    assert seen["after"]["message"] == "no intrusion"
    assert seen["code"] == 0, seen["log"]


def test_soaks_with_nodes_coming_and_going_on_ros2_and_ros1(specs, workspace, tmp_path, rmv):
    """60 s (RMV_SOAK_SECONDS; bench_ros2.py --soak and bench_ros1.py --soak run 10
    minutes) on ROS 2 and, at the same time (each is a minute of wall clock, light on
    the processor), on ROS 1 (tests/ros1/drive_soak.py). An allowed publisher or
    subscriber starts or stops every 2 s, a rogue publisher comes every 10 s for
    4 s. No allowed node is ever reported; every rogue is, within 2 s; the nodes'
    verdicts are those of a replay of what was sent; their memory stays flat after
    the first quarter."""
    seconds = float(os.environ.get("RMV_SOAK_SECONDS", "60"))
    ros1 = _start_ros1_soak(tmp_path / "ros1", seconds)
    run = rosenv.soak(workspace, tmp_path, seconds, rosenv.DOMAIN + 9)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    seen = json.loads(run.stdout)
    # Every rogue within 2 s (docs/ros2.md, "Discovery": before the nodes announced
    # themselves every 0.25 s, one report in five under the suite's load took 3.3 s).
    recording = tmp_path / "sent"
    _record(recording, [tuple(m) for m in seen["sent"]], [stamp for stamp, _ in seen["sent"]])
    replay = rmv("replay", str(specs["soak"]), str(recording), "--format", "jsonl")
    assert_soaked(seen, seconds, replay.out)
    seen1, spec1 = _finish_ros1_soak(*ros1)
    bag = sent_bag(tmp_path / "ros1" / "sent", seen1["sent"])
    assert_soaked(seen1, seconds, rmv("replay", str(spec1), str(bag), "--format", "jsonl").out)


def _start_ros1_soak(folder: Path, seconds: float) -> tuple[Any, Path, Path]:
    """tests/ros1/drive_soak.py on tests/ros1/soak.rmv's rospy nodes, started."""
    sys.path.insert(0, str(HERE.parent / "ros1"))
    import rosenv1

    from rmvdsl.targets import target

    spec = HERE.parent / "ros1" / "soak.rmv"
    package = folder / "soak1"
    target("ros1").build(lower(check(str(spec))), package, {})
    (folder / "logs").mkdir(parents=True)
    command = [rosenv1.python(), str(HERE.parent / "ros1" / "drive_soak.py"),
               str(folder / "logs"), str(package), str(seconds)]  # fmt: skip
    return rosenv1.start(command, folder / "home", folder / "soak"), spec, folder / "soak"


def _finish_ros1_soak(process: Any, spec: Path, out: Path) -> tuple[dict, Path]:
    process.wait(timeout=600)
    stdout = out.with_suffix(".stdout").read_text()
    stderr = out.with_suffix(".stderr").read_text()
    assert process.returncode == 0, stdout[-2000:] + stderr[-4000:]
    return json.loads(stdout), spec


DESCRIBE = """
import json, sys
from std_braking.rmv_host.ros2_definitions import fields_of
out = {}
for name in json.loads(open(sys.argv[1]).read()):
    try:
        out[name] = [[field, kind] for field, kind in fields_of(name)]
    except (ImportError, AttributeError):
        continue  # a package this venv does not install
print(json.dumps(out))
"""


def test_an_installed_class_is_described_as_rosbags_describes_its_definition(workspace, tmp_path):
    """The monitor judges its subscription's class as the replay judges a
    recording's definition (rmvdsl.host.definitions): the class's description
    (rosidl's SLOT_TYPES, read by the package's rmv_host/ros2_definitions.py) is
    rosbags' of the same type, for every type the ROS venv installs that rosbags'
    Kilted store defines (rclpy 9.1 is Kilted's; rosidl gives `char` as uint8)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    names = tmp_path / "names.json"
    names.write_text(json.dumps(sorted(store.fielddefs)), encoding="utf-8")
    run = rosenv.run([rosenv.python(), "-c", DESCRIBE, str(names)], rosenv.DOMAIN + 30, workspace)
    assert run.returncode == 0, run.stderr[-3000:]
    described = json.loads(run.stdout)
    assert len(described) >= 100 and "geometry_msgs/msg/TwistStamped" in described

    def plain(kind: Any) -> Any:  # as JSON gives it back; char as rosidl names it
        number, detail = int(kind[0]), kind[1]
        if number == 1:
            return [1, ["uint8" if detail[0] == "char" else detail[0], detail[1]]]
        return [number, detail] if number == 2 else [number, [plain(detail[0]), detail[1]]]

    for name, fields in described.items():
        expected = [[field, plain(kind)] for field, kind in store.fielddefs[name][1]]
        assert [[field, plain(kind)] for field, kind in fields] == expected, name


def test_generated_python_is_lint_clean_and_names_are_quoted(specs, tmp_path):
    resolved = lower(check(str(specs["std_braking"])))
    package = tmp_path / "package"
    ros2.build(resolved, package)
    lint = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "--config", str(ROOT / "pyproject.toml"),
         str(package)], capture_output=True, text=True,
    )  # fmt: skip
    assert lint.returncode == 0, lint.stdout
    xml = (package / "package.xml").read_text(encoding="utf-8")
    assert "<exec_depend>geometry_msgs</exec_depend>" in xml
    assert "<exec_depend>rclpy</exec_depend>" in xml
    for hostile in ("a'b\"c\\d\n", "</description><evil/>&", "\x00\x1b[31m"):
        assert eval(ros2.py_string(hostile)) == hostile
        assert "<evil/>" not in ros2.xml_text(hostile)
        assert json.loads(ros2.yaml_string(hostile)) == hostile
    with pytest.raises(ros2.BuildError):
        ros2.package_name(resolved, "Bad-Name")


def test_the_collector_writes_every_message_and_survives_influxd_stopping(
    specs, workspace, tmp_path
):
    """The kapacitor target's collector against a real influxd inside the same
    namespace: 60 messages arrive as points, with the transducer's 2 states; with
    influxd stopped, 150 more wait in a buffer of 100 points, the 50 oldest are
    dropped and counted; influxd started again gets the rest."""
    seen = _collect(specs, workspace, tmp_path, [], rosenv.DOMAIN + 5)
    status = seen["status"]
    start, step = 1_700_000_000 * 10**9, 50_000_000
    assert status["messages"] == "210"
    assert status["points dropped: buffer full"] == "50"
    # 160 of the messages, and 2 states: Slow from the first message, Quick at k = 51
    assert status["points written"] == "162"
    assert [s for _, s, _ in seen["states"]] == ["Slow", "Quick"]
    assert [int(t) for t, _, _ in seen["states"]] == [start, start + 51 * step]
    assert float(status["storage delay p99 (ms)"]) > 0
    stored = {int(t): v for t, v in seen["stored"]}
    kept = {(t - start) // step for t in stored}
    assert len(kept) == 160 and all(stored[start + k * step] == k for k in kept)
    assert set(range(60)) <= kept  # written before influxd stopped
    assert set(range(130, 210)) <= kept  # the newest stay; the oldest waiting went
    assert "InfluxDB cannot keep up" in seen["log"]


def test_with_a_spool_the_collector_loses_nothing_while_influxd_is_away(specs, workspace, tmp_path):
    """The same, with a spool file: the 50 points past the memory buffer wait on
    disk, and influxd started again gets all 210 messages and both states. The
    outage lasts RMV_OUTAGE_SECONDS at least (as long as the sending, by default;
    60 s in docs/robustness.md's run)."""
    spool = tmp_path / "spool" / "collector.spool"
    down = float(os.environ.get("RMV_OUTAGE_SECONDS", "0"))
    seen = _collect(specs, workspace, tmp_path, ["-p", f"spool:={spool}", "-p",
                    "spool_bytes:=1000000"], rosenv.DOMAIN + 10, down)  # fmt: skip
    print(f"influxd away for {seen['down_s']} s: {seen['while_down']}")
    assert int(seen["while_down"]["points spooled"]) >= 50, seen["while_down"]
    status = seen["status"]
    assert "points dropped: buffer full" not in status, status
    assert (status["messages"], status["points written"]) == ("210", "212")
    assert status["points spooled"] == "0" and spool.stat().st_size == 0
    start, step = 1_700_000_000 * 10**9, 50_000_000
    stored = {int(t): v for t, v in seen["stored"]}
    assert sorted((t - start) // step for t in stored) == list(range(210))


def _collect(
    specs: dict, workspace: Path, tmp_path: Path, extra: list[str], domain: int, down: float = 0
) -> dict:
    """tests/ros2/drive_collector.py on the `collected` spec's collector (buffer 100,
    and `extra` parameters): 60 messages, influxd stopped, 150 more, influxd back."""
    resolved = lower(check(str(specs["collected"])))
    texts, _ = kapacitor.files(resolved, tmp_path / "build")
    from rmvdsl.dialects.influxql import split as split_statements

    statements = [  # the schema, not the continuous queries: the collector's part only
        s for s in split_statements(texts["influxdb.iql"])
        if not s.startswith("CREATE CONTINUOUS QUERY")
    ]  # fmt: skip
    package = "collected_collector"
    scenario = {
        "influx_root": str(tmp_path / "influxd"),
        "statements": statements,
        "database": "collected",
        "command": [_executable(workspace, package, "collector"), "--ros-args",
                    "-p", "buffer:=100", "-p", "diagnostics_period:=0.2", *extra],
        "before": 60,
        "during": 150,
        "states": 2,
        "down_for": down,
    }  # fmt: skip
    (tmp_path / "influxd").mkdir()
    file = tmp_path / "collector.json"
    file.write_text(json.dumps(scenario), encoding="utf-8")
    run = rosenv.run(
        [rosenv.python(), str(HERE / "drive_collector.py"), str(file)],
        domain, workspace, timeout=240,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    seen = json.loads(run.stdout)
    assert seen["code"] == 0, seen["log"]
    assert seen["while_down"]["_message"].startswith("retrying"), seen["while_down"]
    return seen


def test_the_alert_handler_spools_what_nobody_acknowledges(tmp_path):
    """The kapacitor target's publish handler, run as Kapacitor's `.exec` runs it.
    With no ROS graph listening, alerts wait in a spool of at most 300 bytes: the
    oldest beyond it is dropped and counted. The first run a subscriber hears
    delivers the count, the waiting alerts and its own, in order; an alert whose
    text would break out of a shell arrives as written; a spool that cannot be
    written leaves the alert published without it."""
    spec = lower(check(str(HERE.parent / "fixtures" / "kapacitor" / "hostile.rmv")))
    texts, _ = kapacitor.files(spec, tmp_path / "build")
    handler = tmp_path / "publish_alert.py"
    handler.write_text(texts["handlers/publish_alert.py"], encoding="utf-8")
    hostile = "it's \"bad\" $(touch /tmp/pwned); `id` \\ '''\nnext line \U0001f697"
    waiting = [f"alert {k}: " + "x" * 100 for k in range(3)]
    spool = ["--spool", str(tmp_path / "spool" / "alerts.json")]
    small = [*spool, "--spool-bytes", "300", "--match-timeout", "0.5"]
    (tmp_path / "file").write_text("a file, not a folder")
    unusable = ["--spool", str(tmp_path / "file" / "alerts.json")]
    runs = [
        *({"alert": {"message": text}, "listen": False, "args": small} for text in waiting),
        {"alert": {"id": "A", "message": hostile, "level": "WARNING"}, "listen": True,
         "args": spool},
        {"alert": {"message": "after"}, "listen": True, "args": spool},
        {"alert": {"message": "unspooled"}, "listen": True, "args": unusable},
    ]  # fmt: skip
    scenario = tmp_path / "alerts.json"
    scenario.write_text(json.dumps({"handler": str(handler), "topic": "/rmv/alerts",
                                    "runs": runs}))  # fmt: skip
    run = rosenv.run([rosenv.python(), str(HERE / "drive_alert_handler.py"), str(scenario)],
                     rosenv.DOMAIN + 6, None, timeout=240)  # fmt: skip
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    seen = json.loads(run.stdout)
    assert [r["code"] for r in seen["runs"]] == [3, 3, 3, 0, 0, 0], seen["runs"]
    outputs = [r["output"] for r in seen["runs"]]
    assert "1 alert waits in" in outputs[0] and "2 alerts wait in" in outputs[2], outputs
    assert "cannot be used" in outputs[5], outputs[5]
    assert "the spool holds at most 300 bytes: the oldest alert is dropped" in outputs[2]
    notice = "rmv: 1 alert was lost on /rmv/alerts: nobody acknowledged them and the spool was full"
    assert seen["received"] == [notice, *waiting[1:], hostile, "after", "unspooled"]


def test_the_first_hour_live(workspace, tmp_path):
    """Issue 31's first hour, in one run of the generated package's two nodes, with
    rclpy's ordinary nodes (each publishes /parameter_events and /rosout):

    - Over speed, then silence: the node decides the violation when 1 s of it has
      passed (the message that started it is the last) and shows it in
      /diagnostics within a decide period and a diagnostics period of that.
    - The allowed publisher (/player) is never reported, ROS's own topics included;
      a rogue node is, once, saying who, what and where once each.
    - Subscribers that start after both, transient_local, still get the alert and
      the intrusion.
    (The sourced environment: tests/test_ros_environment.py; late input:
    test_late_input_is_reported_and_unknown_live below.)"""
    command = [_executable(workspace, "overspeed", "monitor"), "--ros-args",
               "-p", "diagnostics_period:=0.05", "-p", "decide_period:=0.05"]  # fmt: skip
    status = "rmv_monitor: property NoLongOverspeed"
    seen = _drive(workspace, {
        "monitor": command, "also": [[_executable(workspace, "overspeed", "intrusion")]],
        "publishers": {"/vehicle/twist": TWIST},
        "steps": [_publish("/vehicle/twist", _twist_cdr(0, 5.0)),
                  _publish("/vehicle/twist", _twist_cdr(0, 30.0)),
                  ["status", status, "false", 15.0],
                  ["intruder", "ros", "/vehicle/twist"],
                  ["status", "rmv_intrusion: intrusions",
                   "1 intrusion: /rogue publisher /vehicle/twist", 15.0]],
        "late": ["/rmv/alerts", "/rmv/intrusion"],
    }, tmp_path, rosenv.DOMAIN + 7)  # fmt: skip
    [(_, _, waited), (_, _, reported)] = seen["waits"]
    print(f"decided {waited} s after the last message")
    # Decidable 1 s after the last message; out within 0.05 + 0.05 s of that, with
    # room for a loaded 2-core machine (measured figures in the closing note).
    assert waited is not None and 1.0 <= waited < 1.6, seen["waits"]
    assert reported is not None, seen["waits"]
    rogue = "intrusion: /rogue not in the publishers allowed on /vehicle/twist"
    assert seen["late"] == {"/rmv/alerts": ["NoLongOverspeed violated"], "/rmv/intrusion": [rogue]}
    assert "/player" not in seen["log"] and seen["log"].count(rogue) == 1, seen["log"]
    # Two levels from one node's actions (rclpy refuses two severities at one call site).
    assert "[WARN]" in seen["log"] and "over speed for too long" in seen["log"]
    assert "[ERROR]" in seen["log"] and "stop the robot" in seen["log"]
    assert seen["others"] == [0]


def test_late_input_is_reported_and_unknown_live(specs, workspace, tmp_path, rmv):
    """Two stamped topics, no lateness: /right's message stamped 1.5 s comes after
    /left's stamped 2 s was fed. The node drops it, counts it per topic in
    /diagnostics, warns once, and its verdicts say unknown where the message would
    have counted, as the replay of the same arrival order does."""
    second = 10**9
    arrivals = [
        ("/left", START + second, 1.0), ("/right", START + second, 1.0),
        ("/left", START + 2 * second, 1.0), ("/right", START + 3 * second // 2, 9.0),
        ("/right", START + 3 * second, 1.0), ("/left", START + 4 * second, 1.0),
    ]  # fmt: skip
    steps: list[list] = []
    for topic, stamp, speed in arrivals:  # each fed before the next is sent
        steps += [_publish(topic, _twist_cdr(stamp, speed)), ["settle"]]
    seen = _drive(workspace, {
        "monitor": [_executable(workspace, "stamped", "monitor")],
        "publishers": {"/left": TWIST, "/right": TWIST}, "steps": steps,
    }, tmp_path, rosenv.DOMAIN + 8)  # fmt: skip
    from_node = [json.loads(v) for v in seen["verdicts"]]
    counters = seen["diagnostics"]["rmv_monitor: monitor"]
    assert counters["late messages dropped: /right"] == "1", counters
    assert seen["log"].count("a message came 0.5 s late") == 1, seen["log"]
    unknown = [(v["from"], v["to"]) for v in from_node if v["verdict"] == "unknown"]
    # From 1.5 s until /right publishes again (3 s): nothing on /right replaced it.
    assert unknown == [(START // second + 1.5, START // second + 3)], from_node

    recording = tmp_path / "arrivals"
    _record(
        recording, [(stamp, speed) for _, stamp, speed in arrivals],
        [START + k for k in range(len(arrivals))], [topic for topic, _, _ in arrivals],
    )  # fmt: skip
    replay = rmv("replay", str(specs["stamped"]), str(recording), "--format", "jsonl")
    # Live, the verdict up to 2 s was out before the message came: revised, where
    # the replay (deciding later) had not given it yet. Each instant reads the same.
    assert [v.get("revised", False) for v in from_node] == [False, True, False]
    from_replay = _verdicts(replay.out)
    instants = _instants(from_node + from_replay)
    assert _read_at(from_node, instants) == _read_at(from_replay, instants)


LOGGED = """
import json, sys
from std_braking.rmv_host.ros2 import log_at
lines = []
class Logger:  # rclpy's, as log_at calls it: a method per severity
    def __getattr__(self, severity):
        return lambda text: lines.append([severity, text])
class Node:
    def get_logger(self):
        return Logger()
for level in ("info", "warn", "error"):
    log_at(Node(), level, sys.argv[1])
print(json.dumps(lines))
"""


def test_a_node_s_log_lines_show_control_characters_as_pictures(workspace):
    """A line a node logs names what recordings and the graph hold: the installed
    package's host logs it safe for a terminal (an escape as ␛, a bell as ␇)."""
    hostile = "/rogue\x1b]0;owned\x07\x1b[31m"
    run = rosenv.run([rosenv.python(), "-c", LOGGED, hostile], rosenv.DOMAIN + 31, workspace)
    assert run.returncode == 0, run.stderr[-4000:]
    shown = "/rogue\u241b]0;owned\u2407\u241b[31m"
    assert json.loads(run.stdout) == [["info", shown], ["warning", shown], ["error", shown]]
