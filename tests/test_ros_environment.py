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
    _clean_then_wrong(spec, sourced, ("drive.gear", "drive.gears"), "gears")


# ---- ROS 1, as Debian installs it (.ci/run installs ros-*-msgs) ----

DEBIAN_ROS1 = Path("/usr/share")


@pytest.fixture(scope="module")
def sourced_ros1() -> dict[str, str]:
    """ROS 1's environment: ROS_PACKAGE_PATH names the folders of packages (Debian
    installs each package's messages under /usr/share/PACKAGE/msg)."""
    assert (DEBIAN_ROS1 / "std_msgs" / "msg" / "Header.msg").is_file(), "apt: ros-std-msgs"
    return {**os.environ, "ROS_PACKAGE_PATH": str(DEBIAN_ROS1)}


@pytest.mark.parametrize("spec", GOOD)
def test_every_example_checks_in_a_sourced_ros1_environment(spec, sourced_ros1, tmp_path):
    copy = tmp_path / "examples"
    shutil.copytree(EXAMPLES, copy)
    result = rmv_process(["check", "--no-color", str(copy / spec)], cwd=tmp_path, env=sourced_ros1)
    assert result.code == 0, result.out + result.err
    assert result.out.strip().endswith("0 errors, 0 warnings"), result.out


def test_a_ros1_package_on_the_package_path_uses_debian_s_messages(sourced_ros1, tmp_path):
    """A workspace package (on ROS_PACKAGE_PATH beside Debian's) whose message
    embeds std_msgs/Header and geometry_msgs/Twist: its fields resolve through
    the installed definitions, and a wrong one is found."""
    package = tmp_path / "src" / "robot_msgs" / "msg"
    package.mkdir(parents=True)
    (package / "Drive.msg").write_text(
        "Header header\ngeometry_msgs/Twist command\nuint8 gear\nfloat64[4] wheel_speeds\n",
        encoding="utf-8",
    )
    env = {**sourced_ros1, "ROS_PACKAGE_PATH": f"{tmp_path / 'src'}{os.pathsep}{DEBIAN_ROS1}"}
    spec = tmp_path / "drive.rmv"
    spec.write_text(
        'system drive\nros noetic\ntopic drive: robot_msgs/Drive = "/drive" qos { time = header }\n'
        "var Speed = drive.command.linear.x\nvar Gear = drive.gear\nvar Frame = drive.header.seq\n"
        "event TooFast when Speed > 10 and Gear < 2 and Frame > 0\n"
        "property Safe: not TooFast\n",
        encoding="utf-8",
    )
    _clean_then_wrong(spec, env, ("linear.x", "linear.w"), "`w`")


def _clean_then_wrong(spec: Path, env: dict[str, str], edit: tuple[str, str], said: str) -> None:
    """`spec` checks clean in `env`; with one field misspelt (`edit`), the check
    fails and says `said`."""
    result = rmv_process(["check", "--no-color", str(spec)], cwd=spec.parent, env=env)
    assert result.code == 0, result.out + result.err
    spec.write_text(spec.read_text(encoding="utf-8").replace(*edit), encoding="utf-8")
    result = rmv_process(["check", "--no-color", str(spec)], cwd=spec.parent, env=env)
    assert result.code == 1 and said in result.out, result.out
