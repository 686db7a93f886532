"""`rmv build --target ros1` on Debian's ROS 1 (rospy 1.15, rosmaster, rosbag),
every process inside a private network namespace holding only loopback, with a
master of its own on 127.0.0.1."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from conftest import ROOT, per_property

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.targets import target

sys.path.insert(0, str(Path(__file__).resolve().parent / "ros1"))
import rosenv1

HERE = Path(__file__).resolve().parent / "ros1"
CARLA = ROOT / "examples" / "carla"
BAG = CARLA / "recordings" / "braking.bag"


def _carla_spec() -> str:
    """examples/carla/abs.rmv with times from header stamps and deep reader queues.
    The two topics come over two TCP connections, read by two threads: one may be
    read a little after the other, so the lateness covers the whole recording
    (28 s of stamps, played at ten times its speed)."""
    text = (CARLA / "abs.rmv").read_text(encoding="utf-8")
    text = text.replace('messages "msg"', f"messages {json.dumps(str(CARLA / 'msg'))}")
    qos = "    depth = 1000\n    time = header\n"
    text = text.replace("    depth = 10\n    reliability = reliable\n", qos)
    objects = '"/carla/hero/objects"\n'
    text = text.replace(objects, f"{objects[:-1]} qos {{\n{qos}}}\n")
    assert text.count("time = header") == 2
    return text.replace("    trigger = always\n", "    trigger = always\n    lateness = 30s\n")


def _build(spec: Path, out: Path) -> Path:
    result = check(str(spec))
    assert not result.errors, [str(d) for d in result.errors]
    target("ros1").build(lower(result), out, {})
    return out


@pytest.fixture(scope="module")
def carla(tmp_path_factory) -> tuple[Path, Path]:
    """The CARLA spec above and its package."""
    folder = tmp_path_factory.mktemp("carla")
    spec = folder / "abs.rmv"
    spec.write_text(_carla_spec(), encoding="utf-8")
    return spec, _build(spec, folder / "carla_abs")


def _drive(script: str, *args: str, home: Path, timeout: float = 240) -> dict:
    """A driver of tests/ros1/ inside a namespace of its own; the JSON it prints."""
    logs = home / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    result = rosenv1.run(
        [rosenv1.python(), str(HERE / script), str(logs), *args], home, timeout=timeout
    )
    assert result.returncode == 0, result.stderr[-4000:] + result.stdout[-2000:]
    return json.loads(result.stdout)


def test_the_package_is_a_catkin_package(carla):
    _, package = carla
    manifest = ET.parse(package / "package.xml").getroot()
    assert manifest.get("format") == "3"
    assert manifest.findtext("name") == "carla_abs"
    assert [e.text for e in manifest.findall("buildtool_depend")] == ["catkin"]
    # AnyMsg and the connection header's definitions: no carla_msgs to depend on.
    assert [e.text for e in manifest.findall("exec_depend")] == [
        "rospy", "rosgraph", "std_msgs", "diagnostic_msgs",
    ]  # fmt: skip
    for script in ("monitor", "intrusion"):
        assert os.access(package / "scripts" / script, os.X_OK)
    launch = ET.parse(package / "launch" / "monitor.launch").getroot()
    assert [n.get("name") for n in launch.iter("node")] == ["rmv_monitor", "rmv_intrusion"]
    lint = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "--no-cache", "--select", "E,F,W,I,UP,B",
         "--target-version", "py311", str(package / "src"), str(package / "setup.py")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert lint.returncode == 0, lint.stdout
    # The ROS 1 package carries the ROS 1 host and not the ROS 2 one.
    host = {p.name for p in (package / "src" / "carla_abs" / "rmv_host").iterdir()}
    assert {"ros1.py", "ros1_graph.py", "ros1_decoding.py"} <= host
    assert "ros2.py" not in host


def test_catkin_make_builds_it_and_roslaunch_runs_it(carla, tmp_path):
    """Debian's catkin builds the package in a workspace (the scripts' Python is the
    one with rosbags: -DPYTHON_EXECUTABLE) and installs the scripts, the Python
    package, the launch file and the parameters; `roslaunch` from the install
    space starts both nodes with the parameters. Debian's own Python, which lacks
    rosbags, stops the monitor at start with the command that installs it."""
    _, package = carla
    shutil.copytree(package, tmp_path / "src" / "carla_abs")
    env = {**rosenv1.scrubbed_environment(), "ROS_HOME": str(tmp_path / "home")}
    python = f"-DPYTHON_EXECUTABLE={rosenv1.python()}"
    command = ["catkin_make", "-C", str(tmp_path), "install", python]
    result = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True,
                            timeout=300)  # fmt: skip
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    installed = tmp_path / "install"
    for script in ("monitor", "intrusion"):
        assert os.access(installed / "lib" / "carla_abs" / script, os.X_OK)
    assert (installed / "share" / "carla_abs" / "launch" / "monitor.launch").exists()
    assert (installed / "share" / "carla_abs" / "config" / "params.yaml").exists()
    specs = list(installed.rglob("carla_abs/spec.json"))
    assert specs and (specs[0].parent / "rmv_host" / "ros1.py").exists()
    seen = _drive("drive_launch.py", str(tmp_path), "carla_abs", home=tmp_path / "run")
    assert {"/rmv_monitor", "/rmv_intrusion"} <= set(seen["nodes"]), seen["log"]
    assert seen["topic parameter"] == "/carla/hero/vehicle_status"
    assert seen["bare_exit"] == 1, seen["bare_output"]
    assert "pip install rosbags" in seen["bare_output"], seen["bare_output"]


def test_rosbag_play_into_the_monitor_gives_the_replay_s_verdicts(carla, tmp_path, rmv):
    """The README's CARLA bag, played by `rosbag play` at ten times its speed into
    the generated monitor, run straight from its folder: every message decoded
    from its connection header (no carla_msgs is installed), and the segments
    published on /rmv/verdicts are the replay's, segment for segment."""
    spec, package = carla
    seen = _drive("drive_monitor.py", str(package), str(BAG), "-r", "10", home=tmp_path)
    assert seen["play_exit"] == 0 and seen["monitor_exit"] == 0, seen["monitor_log"]
    replay = rmv("replay", str(spec), str(BAG), "--format", "jsonl")
    assert replay.code == 1, replay.err
    from_replay = [json.loads(line) for line in replay.out.splitlines() if '"verdict"' in line]
    assert per_property(seen["verdicts"]) == per_property(from_replay)
    violated = {v["property"] for v in from_replay if v["verdict"] == "false"}
    assert violated == {"ABSCheck"}
    counters = seen["counters"]
    assert counters["messages"] == "900", seen["monitor_log"]
    assert not [k for k in counters if "late" in k or "damaged" in k or "lost" in k], counters


GUARD = """system guard "a whitelisted topic on ROS 1"
ros noetic
topic cmd: geometry_msgs/Twist = "/cmd"
var Speed = cmd.linear.x
event Fast when Speed > 100
property NeverFast: not Fast
whitelist cmd {
    publishers: "/driver", "/allowed_*"
    subscribers: "/base", "/allowed_*", "/victim"
}
intrusion {
    poll = 200ms
}
"""


def _reports(seen: dict, name: str, after: float, until: float | None = None) -> list[dict]:
    """The node's statuses `rmv_intrusion: NAME` not OK, between two steps."""
    return [
        s for s in seen["statuses"]
        if s["name"] == f"rmv_intrusion: {name}" and s["level"] != 0
        and s["t"] >= after and (until is None or s["t"] < until)
    ]  # fmt: skip


def _first_naming(
    seen: dict, name: str, who: str, after: float, since: float | None = None
) -> float | None:
    """Seconds from `after` to the first status `NAME` whose message names `who`,
    looking from `since` on (default: `after`)."""
    for status in _reports(seen, name, after if since is None else since):
        if who in status["message"]:
            return status["t"] - after
    return None


def _naming(line: str, nodes: list[str]) -> bool:
    """Whether a log line names one of `nodes` (`/allowed_1` is not `/allowed_12`)."""
    return any(re.search(re.escape(node) + r"(?![\w/])", line) for node in nodes)


def _peer_logs(home: Path, lines: list[str], seen: dict) -> str:
    """The lines that named a node, then the node's log and rospy's log of each
    node named (what it did around then), and how each peer exited."""
    text = ["\n".join(lines), f"peer exits: {seen['peer exits']}"]
    for name in sorted({w.strip(":") for line in lines for w in line.split() if "/" in w}):
        file = f"{name.strip('/')}.log"
        for log in (home / "logs" / file, home / "log" / file):
            if log.is_file():
                text.append(f"--- {log}\n{log.read_text(errors='replace')[-4000:]}")
    return "\n".join(text) + "\n--- the intrusion node\n" + seen["log"]


def test_the_intrusion_node_reports_rogues_sneaks_and_stale_nodes_and_no_allowed_node(tmp_path):
    """Debian's rosmaster, rospy nodes and the generated intrusion node, run straight
    from its folder: 20 allowed nodes starting and stopping give no report; a rogue
    publisher and a rogue subscriber are each reported within 2 s; so is a publisher
    that unregistered and reached a subscriber directly (by its XML-RPC address: the
    master never lists it); a node frozen with SIGSTOP for 6 s (its calls time out) is
    not stale, a node killed with SIGKILL is (after its 3 s grace)."""
    spec = tmp_path / "guard.rmv"
    spec.write_text(GUARD, encoding="utf-8")
    package = _build(spec, tmp_path / "guard")
    seen = _drive("drive_intrusion.py", str(package), "/cmd", "20", home=tmp_path / "run")
    steps = seen["steps"]
    assert seen["exit"] == 0, seen["log"]
    assert not _reports(seen, "intrusions", 0.0, steps["/rogue_pub start"]), seen["log"]
    # A peer that had to be killed (it did not stop within 15 s of SIGINT: a loaded
    # machine) stays registered, and is rightly stale; every other allowed node
    # must go unnamed.
    killed = sorted(n for n, code in seen["peer exits"].items() if code and n != "/victim")
    judged = [line for line in seen["log"].splitlines() if not _naming(line, killed)]
    if killed:  # why they did not stop: their logs (with their threads' stacks)
        print(_peer_logs(tmp_path / "run", [f"killed: {' '.join(killed)}"], seen))
    for name in ("/driver", "/base", "/allowed_", "/rmv_intrusion", "/rosout"):
        named = [line for line in judged if name in line]
        assert not named, _peer_logs(tmp_path / "run", named, seen)
    # From when the driver saw each registered (or connected): the node may see it
    # first (a loaded machine delays the driver's polls), so each report is looked
    # for from the start of its process.
    latencies = {
        who: _first_naming(seen, "intrusions", who, steps[step], steps[f"{step} start"])
        for who, step in (("/rogue_pub", "/rogue_pub"), ("/rogue_sub", "/rogue_sub"))
    }
    sneak = steps["sneak uri"].split("//")[1].rstrip("/")
    latencies[sneak] = _first_naming(
        seen, "intrusions", sneak, steps["sneak"], steps["sneak start"]
    )
    print(f"reported after (s): {latencies}")
    assert all(t is not None and t <= 2.0 for t in latencies.values()), (latencies, seen["log"])
    assert "without registering with the ROS master" in seen["log"]
    stale = _first_naming(seen, "stale nodes", "/victim", steps["victim killed"])
    # its grace (3 s), a poll (0.2 s) and the poll's calls
    assert stale is not None and stale <= 4.5, seen["statuses"][-3:]
    assert "stale: /victim" in seen["log"] and "intrusion: /victim" not in seen["log"]
    # nodes that stop are not stale (one killed after 15 s is)
    assert sum("stale:" in line for line in judged) == 1, _peer_logs(tmp_path / "run", judged, seen)


SIMULATED = """system simulated "sim time, parameters, lost and wrong-type messages"
ros noetic
topic twist: geometry_msgs/TwistStamped = "/vehicle/twist"
topic wrong: geometry_msgs/TwistStamped = "/wrong"
var Speed = twist.twist.linear.x
var Other = wrong.twist.linear.x
event Fast when Speed > 25
event OtherFast when Other > 5
property NeverFast: not Fast {
    action publish("/rmv/alerts")
}
property OtherSlow: not OtherFast
"""
SIM_START = 1_600_000_000 * 10**9


def _simulated_bag(path: Path) -> Path:
    """3 s of TwistStamped on /other at 10 Hz whose header seq skips 11 and 12 (two
    messages lost before the recording), over 25 from 2 s on; and std_msgs/Float64
    on /wrong, a topic the spec reads as TwistStamped."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    Twist = store.types["geometry_msgs/msg/TwistStamped"]
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    Vector3, Inner = (
        store.types["geometry_msgs/msg/Vector3"],
        store.types["geometry_msgs/msg/Twist"],
    )
    Float64 = store.types["std_msgs/msg/Float64"]
    with Writer(path) as writer:
        twist = writer.add_connection("/other", Twist.__msgtype__, typestore=store)
        wrong = writer.add_connection("/wrong", Float64.__msgtype__, typestore=store)
        for k in range(1, 33):
            if k in (11, 12):
                continue
            t = SIM_START + k * 100_000_000
            stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
            speed = 30.0 if k >= 20 else 10.0
            message = Twist(
                header=Header(seq=k, stamp=stamp, frame_id=""),
                twist=Inner(
                    linear=Vector3(x=speed, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0)
                ),
            )
            writer.write(twist, t, store.serialize_ros1(message, Twist.__msgtype__))
            if k % 10 == 0:
                writer.write(wrong, t, store.serialize_ros1(Float64(data=1.0), Float64.__msgtype__))
    return path


def test_sim_time_parameters_renames_lost_and_wrong_messages(tmp_path):
    """`/use_sim_time` with `rosbag play --clock`: receipt times are the bag's clock,
    not the system's; `__name:=watcher` renames the node; `_topics/twist:=/other`
    reads another topic; a gap in the headers' `seq` counts 2 lost messages, unknown
    where they were; a topic
    carrying another type than the spec's counts each message damaged; the
    violation's `publish` action is latched: a subscriber that comes later gets it."""
    spec = tmp_path / "simulated.rmv"
    spec.write_text(SIMULATED, encoding="utf-8")
    package = _build(spec, tmp_path / "simulated")
    bag = _simulated_bag(tmp_path / "simulated.bag")
    seen = _drive(
        "drive_monitor.py", str(package), str(bag), "--sim", "--node", "/watcher",
        "--arg", "_topics/twist:=/other", "--arg", "_diagnostics_period:=0.2",
        "--late", "/rmv/alerts", home=tmp_path / "run",
    )  # fmt: skip
    assert seen["monitor_exit"] == 0, seen["monitor_log"]
    assert seen["verdict_publishers"] == ["/watcher"]
    assert seen["late"] == {"/rmv/alerts": ["NeverFast violated"]}, seen["monitor_log"]
    counters = seen["counters"]
    assert counters["messages"] == "30", counters  # decoded ones; the damaged apart
    assert counters["lost messages: /vehicle/twist"] == "2", counters
    assert counters["damaged messages: /wrong"] == "3", counters
    verdicts = per_property(seen["verdicts"])
    start, end = SIM_START / 1e9, SIM_START / 1e9 + 4
    for segment in seen["verdicts"]:
        assert start <= float(segment["from"]) <= end, segment  # the bag's clock
    # Unknown where the 2 messages were lost (after the one of 1.0 s, until 1.3 s),
    # then false from 2 s.
    never = verdicts["NeverFast"]
    assert [v["verdict"] for v in never][:4] == ["true", "unknown", "true", "false"], verdicts
    lost = never[1]
    assert 0.95 <= float(lost["from"]) - start <= 1.15 and 1.25 <= float(lost["to"]) - start <= 1.45
    assert (
        "sends std_msgs/msg/Float64 on /wrong, the spec reads geometry_msgs/msg/TwistStamped"
        in seen["monitor_log"]
    )


DEFINITIONS = """system definitions "a publisher's definition unlike the spec's"
ros noetic
topic v: geometry_msgs/Vector3Stamped = "/v" qos {
    depth = 1000
    time = header
}
topic hb: std_msgs/String = "/hb"
var X = v.vector.x
var Y = v.vector.y
event Fast when X > 100
event Far when Y > 100
property NeverFast: not Fast
property NeverFar: not Far
whitelist hb {
    publishers: "/play_*"
}
"""


def _definitions_bag(path: Path) -> Path:
    """2 s of Vector3Stamped on /v at 10 Hz, defined with `string x` (numbers as
    text, "150": past Fast's bound if read as a number), `y` past Far's bound from
    1 s; and /hb, which the spec reads no field of, whose bytes do not decode."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    for name, text in (
        ("builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec"),
        ("std_msgs/msg/Header", "uint32 seq\ntime stamp\nstring frame_id"),
        ("std_msgs/msg/String", "string data"),
        ("geometry_msgs/msg/Vector3", "string x\nfloat64 y\nfloat64 z"),
        (
            "geometry_msgs/msg/Vector3Stamped",
            "std_msgs/Header header\ngeometry_msgs/Vector3 vector",
        ),
    ):
        store.register(get_types_from_msg(text, name))
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    Stamped, Vector3 = (
        store.types["geometry_msgs/msg/Vector3Stamped"],
        store.types["geometry_msgs/msg/Vector3"],
    )
    with Writer(path) as writer:
        v = writer.add_connection("/v", Stamped.__msgtype__, typestore=store)
        hb = writer.add_connection("/hb", "std_msgs/msg/String", typestore=store)
        for k in range(1, 21):
            t = SIM_START + k * 100_000_000
            stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
            vector = Vector3(x="150", y=200.0 if k > 10 else 1.0, z=0.0)
            message = Stamped(header=Header(seq=k, stamp=stamp, frame_id=""), vector=vector)
            writer.write(v, t, store.serialize_ros1(message, Stamped.__msgtype__))
            writer.write(hb, t, (1000).to_bytes(4, "little") + b"abc")  # 1,000 bytes said
    return path


def test_a_publisher_s_definition_is_judged_as_the_replay_judges_a_recording(tmp_path, rmv):
    """A ROS 1 publisher's definition (its connection header, here `rosbag play`'s
    from the bag) holding a field of another kind than the spec reads (`string x`
    for a float64) skips that variable, with the replay's warning, in place of
    reading "150" as 150; and a topic the spec reads no field of is not decoded
    (its garbled bytes are no damage): the live monitor's verdicts and counters are
    the replay's of the same bag."""
    spec = tmp_path / "definitions.rmv"
    spec.write_text(DEFINITIONS, encoding="utf-8")
    package = _build(spec, tmp_path / "definitions")
    bag = _definitions_bag(tmp_path / "definitions.bag")
    seen = _drive("drive_monitor.py", str(package), str(bag), home=tmp_path / "run")
    assert seen["play_exit"] == 0 and seen["monitor_exit"] == 0, seen["monitor_log"]
    replay = rmv("replay", str(spec), str(bag), "--format", "jsonl")
    assert replay.code == 1, replay.err
    records = [json.loads(line) for line in replay.out.splitlines()]
    warned = [r["message"] for r in records if r["kind"] == "diagnostic"]
    kind = "`geometry_msgs/msg/Vector3Stamped.vector.x` is string in {}, the spec reads float64"
    assert warned == ["variable `X` on /v: " + kind.format("the recording")], warned
    assert "variable `X` on /v: " + kind.format("its publisher's definition") in seen["monitor_log"]
    from_replay = [r for r in records if r["kind"] == "verdict"]
    assert per_property(seen["verdicts"]) == per_property(from_replay), seen["monitor_log"]
    assert [v["verdict"] for v in per_property(from_replay)["NeverFar"]] == ["true", "false"]
    counters = seen["counters"]
    assert counters["messages"] == "40", counters
    assert not [k for k in counters if "damaged" in k or "matching" in k], counters


def test_the_kapacitor_collector_on_ros1_stores_every_message(tmp_path):
    """`rmv build --target kapacitor --collector ros1`: the thesis's rostopicmon as a
    catkin package; the CARLA bag played into it by `rosbag play` arrives in a real
    influxd (inside the same namespace) as one point per message, with the braking
    transducer's states, and nothing dropped. (Times of receipt: the example's
    retention policy keeps a day, and the bag's stamps are of 2023.)"""
    from rmvdsl.dialects.influxql import split as split_statements

    spec = tmp_path / "abs.rmv"
    text = (CARLA / "abs.rmv").read_text(encoding="utf-8")
    # Every message, as the spec asks: keep_all. (With the example's depth of 10,
    # rospy drops the oldest when the collector falls behind a 10x `rosbag play`,
    # and this bag's headers carry no `seq` to count them by: docs/ros1.md, Limits.)
    text = text.replace("qos {\n    depth = 10\n", "qos {\n    history = keep_all\n")
    objects = '"/carla/hero/objects"'
    text = text.replace(f"{objects}\n", f"{objects} qos {{\n    history = keep_all\n}}\n")
    assert text.count("history = keep_all") == 2
    spec.write_text(text.replace('messages "msg"', f"messages {json.dumps(str(CARLA / 'msg'))}"))
    build = tmp_path / "build"
    built = target("kapacitor").build(lower(check(str(spec))), build, {"collector": "ros1"})
    assert build / "collector" / "scripts" / "collector" in built.files
    statements = [
        s for s in split_statements((build / "influxdb.iql").read_text(encoding="utf-8"))
        if not s.startswith("CREATE CONTINUOUS QUERY")
    ]  # fmt: skip
    (tmp_path / "influxd").mkdir()
    scenario = tmp_path / "scenario.json"
    scenario.write_text(json.dumps({
        "influx_root": str(tmp_path / "influxd"), "statements": statements,
        "database": "rmvcps_db", "measurement": "carla_abs", "states": "carla_abs_states",
        "collector": str(build / "collector" / "scripts" / "collector"),
        "topic": "/carla/hero/vehicle_status", "bag": str(BAG), "expected": 600,
    }), encoding="utf-8")  # fmt: skip
    seen = _drive("drive_collector.py", str(scenario), home=tmp_path / "run")
    assert seen["exit"] == 0 and seen["play_exit"] == 0, seen["log"]
    from rosbags.highlevel import AnyReader

    with AnyReader([BAG]) as reader:
        recorded = {c.topic: c.msgcount for c in reader.connections}
    spec_topics = ("/carla/hero/vehicle_status", "/carla/hero/objects")
    assert seen["per_topic"] == {t: recorded[t] for t in spec_topics}, seen["log"]
    assert seen["states"] >= 2, seen
    status = seen["status"]
    assert status["messages"] == str(sum(recorded[t] for t in spec_topics)), status
    assert not [k for k in status if "dropped" in k or "lost" in k or "damaged" in k], status


LOGGED = """
import json, sys
import rospy
sys.path.insert(0, sys.argv[2])  # the package's Python: what catkin installs
lines = []
for level in ("logdebug", "loginfo", "logwarn", "logerr", "logfatal"):
    setattr(rospy, level, lambda text, level=level: lines.append([level, text]))
from carla_abs.rmv_host.ros1 import log_at
for level in ("info", "warn", "error"):
    log_at(level, sys.argv[1])
print(json.dumps(lines))
"""


def test_a_node_s_log_lines_show_control_characters_as_pictures(carla, tmp_path):
    """A ROS 1 node's name is any caller id it registered with the master, and an
    intrusion's line names it: the built package's host logs it safe for a terminal
    (an escape as ␛, a bell as ␇), on Debian's rospy."""
    _, package = carla
    script = tmp_path / "logged.py"
    script.write_text(LOGGED, encoding="utf-8")
    hostile = "/rogue\x1b]0;owned\x07\x1b[31m"
    command = [rosenv1.python(), str(script), hostile, str(package / "src")]
    result = rosenv1.run(command, tmp_path, timeout=120)
    assert result.returncode == 0, result.stderr[-4000:]
    lines = json.loads(result.stdout)
    shown = "/rogue\u241b]0;owned\u2407\u241b[31m"
    assert lines == [["loginfo", shown], ["logwarn", shown], ["logerr", shown]]
