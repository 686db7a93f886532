"""`rmv build --target ros2` on real ROS 2 (the PyPI wheels), inside a private
network namespace holding only loopback: nothing can leave the machine."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

from rmvdsl.check import check
from rmvdsl.codegen import ros2
from rmvdsl.ir import lower

DRIVER = Path(__file__).resolve().parent / "ros2" / "drive_monitor.py"
START = 1_700_000_000 * 10**9
SPEC = """system std_braking "braking, in standard ROS 2 types"
time unit s
topic twist: geometry_msgs/msg/TwistStamped = "/vehicle/twist" qos {
    depth = 1000
    time = header
}
var Speed = twist.twist.linear.x
event Fast when Speed > 25
event Stopped when Speed < 0.1
/// Fast for less than 2 s of every 4 s.
property NotFastLong: duration[4s](Fast) < 2s
property NeverStops: not Stopped
"""


def _speed(k: int) -> float:
    """20 m/s, then 30 m/s for 3 s from 2 s, braking to a stop at 8 s."""
    if k < 40:
        return 20.0
    if k < 100:
        return 30.0
    return max(0.0, 30.0 - (k - 100) * 0.5)


MESSAGES = [(START + k * 50_000_000, _speed(k)) for k in range(200)]


@pytest.fixture(scope="module")
def spec(tmp_path_factory):
    folder = tmp_path_factory.mktemp("spec")
    path = folder / "std_braking.rmv"
    path.write_text(SPEC, encoding="utf-8")
    result = check(str(path))
    assert not result.errors, [str(d) for d in result.errors]
    return path, lower(result)


# The ROS 2 wheels live in a virtual environment of their own: ros-rosidl-parser
# needs lark-parser 0.12, which installs over the `lark` 1.3 that rmvdsl's parser
# needs. The generated package embeds a standard-library runtime, so it needs
# nothing from rmvdsl's environment.
ROS_WHEELS = (
    "ros-rclpy==9.1.2", "ros-std-msgs==5.5.1", "ros-diagnostic-msgs==5.5.1",
    "ros-geometry-msgs==5.5.1", "ros-rmw-fastrtps-cpp==9.3.3",
)  # fmt: skip
ROS_VENV = ROOT / ".ros-venv"


@pytest.fixture(scope="session")
def ros_python() -> str:
    """The Python of .ros-venv, made (once) with the ROS 2 wheels from PyPI."""
    python = ROS_VENV / "bin" / "python"
    marker = ROS_VENV / "rmvdsl-wheels.txt"
    wanted = "\n".join(ROS_WHEELS)
    if not python.exists() or not marker.exists() or marker.read_text() != wanted:
        subprocess.run([sys.executable, "-m", "venv", "--clear", str(ROS_VENV)], check=True)
        install = subprocess.run(
            [str(python), "-m", "pip", "install", "--quiet", *ROS_WHEELS],
            capture_output=True, text=True, timeout=900,
        )  # fmt: skip
        assert install.returncode == 0, install.stderr[-3000:]
        marker.write_text(wanted)
    return str(python)


def _in_namespace(command: list[str], domain: int) -> subprocess.CompletedProcess[str]:
    """Run inside `unshare -rn` with loopback up, discovery confined to this host."""
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        pytest.fail("the ROS 2 tests need unshare (util-linux) and ip (iproute2)")
    env = {
        **os.environ,
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_DOMAIN_ID": str(domain),
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
    }
    script = 'ip link set lo up && exec "$@"'
    return subprocess.run(
        ["unshare", "-rn", "sh", "-c", script, "sh", *command],
        env=env, capture_output=True, text=True, timeout=180,
    )  # fmt: skip


def _record(path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection(
            "/vehicle/twist", "geometry_msgs/msg/TwistStamped", typestore=store
        )
        for stamp, speed in MESSAGES:
            message = types["geometry_msgs/msg/TwistStamped"](
                header=types["std_msgs/msg/Header"](
                    stamp=types["builtin_interfaces/msg/Time"](*divmod(stamp, 10**9)),
                    frame_id="",
                ),
                twist=types["geometry_msgs/msg/Twist"](
                    linear=types["geometry_msgs/msg/Vector3"](speed, 0.0, 0.0),
                    angular=types["geometry_msgs/msg/Vector3"](0.0, 0.0, 0.0),
                ),
            )
            data = store.serialize_cdr(message, "geometry_msgs/msg/TwistStamped")
            writer.write(connection, stamp, data)


def test_the_node_publishes_the_replays_verdicts(spec, tmp_path, rmv, ros_python):
    path, resolved = spec
    package = tmp_path / "package"
    ros2.build(resolved, package)
    scenario = tmp_path / "scenario.json"
    scenario.write_text(json.dumps({"topic": "/vehicle/twist", "messages": MESSAGES}))
    run = _in_namespace(
        [ros_python, str(DRIVER), str(package), "std_braking", str(scenario)], domain=57
    )
    assert run.returncode == 0, run.stdout + run.stderr
    seen = json.loads(run.stdout)
    assert seen["code"] == 0, seen["log"]
    from_node = [json.loads(v) for v in seen["verdicts"]]

    recording = tmp_path / "twist"
    _record(recording)
    replay = rmv("replay", str(path), str(recording), "--format", "jsonl")
    assert replay.code == 1, replay.err
    from_replay = [
        json.loads(line) for line in replay.out.splitlines() if '"kind": "verdict"' in line
    ]
    assert len(from_replay) >= 4
    assert from_node == from_replay
    # Fast from 2 s to 5 s: more than 2 s of 4 s from 0 s (2 + ...) to 3 s
    violated = [v for v in from_node if v["verdict"] == "false"]
    assert {v["property"] for v in violated} == {"NotFastLong", "NeverStops"}
    diagnostics = seen["diagnostics"]
    assert diagnostics["rmv_monitor: monitor"]["messages"] == "200"
    assert diagnostics["rmv_monitor: property NotFastLong"]["formula"]


def test_generated_python_is_lint_clean_and_names_are_quoted(spec, tmp_path):
    _, resolved = spec
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
