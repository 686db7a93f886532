"""`rmv check` in a sourced ROS environment (issue 31): the message types of the
install the user sourced, as ROS 2's setup scripts leave them (each message as
X.msg and the X.idl generated from it), and packages that ship .idl only."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest
from conftest import EXAMPLES, rmv_process

sys.path.insert(0, str(Path(__file__).parent / "ros2"))
import rosenv

GOOD = ["carla/abs.rmv", "gazebo/prius_platoon.rmv", "gazebo/network.rmv"]


@pytest.fixture(scope="module")
def sourced(tmp_path_factory) -> dict[str, str]:
    """What `source install/setup.bash` of the PyPI ROS 2 wheels sets."""
    rosenv.python()  # the wheels' share/ folders: .msg beside .idl for every type
    return {**os.environ, "AMENT_PREFIX_PATH": str(rosenv.VENV)}


@pytest.mark.parametrize("spec", GOOD)
def test_every_example_checks_in_a_sourced_ros2_environment(spec, sourced, tmp_path):
    """It was 97 RMV304 for abs.rmv: the .idl beside each .msg did not parse."""
    copy = tmp_path / "examples"
    shutil.copytree(EXAMPLES, copy)
    result = rmv_process(["check", "--no-color", str(copy / spec)], cwd=tmp_path, env=sourced)
    assert result.code == 0, result.out + result.err
    assert result.out.strip().endswith("0 errors, 0 warnings"), result.out


def test_a_package_with_idl_only(sourced, tmp_path):
    """Where only the .idl exists it is read: its includes, modules, constants and
    bounded sequences."""
    package = tmp_path / "msgs" / "robot_msgs" / "msg"
    package.mkdir(parents=True)
    (package / "Drive.idl").write_text(
        '#include "geometry_msgs/msg/Twist.idl"\n\n'
        "module robot_msgs {\n  module msg {\n"
        "    module Drive_Constants {\n      const uint8 MAX_GEAR = 5;\n    };\n"
        "    struct Drive {\n      geometry_msgs::msg::Twist command;\n"
        "      uint8 gear;\n      sequence<double, 4> wheel_speeds;\n    };\n  };\n};\n",
        encoding="utf-8",
    )
    spec = tmp_path / "drive.rmv"
    spec.write_text(
        'system drive\nros humble\nmessages "msgs"\n'
        'topic drive: robot_msgs/msg/Drive = "/drive"\n'
        "var Speed = drive.command.linear.x\nvar Gear = drive.gear\n"
        "var Fastest = max(drive.wheel_speeds[*])\n"
        "event TooFast when Speed > 10 and Gear < 2 and Fastest > 12\n"
        "property Safe: not TooFast\n",
        encoding="utf-8",
    )
    result = rmv_process(["check", "--no-color", str(spec)], cwd=tmp_path, env=sourced)
    assert result.code == 0, result.out + result.err
    wrong = spec.read_text(encoding="utf-8").replace("drive.gear", "drive.gears")
    spec.write_text(wrong, encoding="utf-8")
    result = rmv_process(["check", "--no-color", str(spec)], cwd=tmp_path, env=sourced)
    assert result.code == 1 and "gears" in result.out, result.out
