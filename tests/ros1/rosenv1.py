"""ROS 1 as Debian ships it (bookworm, 1.15), for the tests and benchmarks: a
virtual environment of Debian's Python with its site packages (rospy and the
ROS tools) plus rosbags from PyPI, and every ROS 1 process inside a private
network namespace holding only loopback, with a master of its own on 127.0.0.1.
"""

from __future__ import annotations

import os
import subprocess
import sys
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# The namespace and the venv are made as for ROS 2 (tests/ros2/rosenv.py).
sys.path.insert(0, str(ROOT / "tests" / "ros2"))
from rosenv import isolated, made_venv  # noqa: E402

VENV = ROOT / ".ros1-venv"
DEBIAN_PYTHON = "/usr/bin/python3"
# What the generated nodes need beside Debian's ROS 1: the rosbags rmvdsl runs on here.
WHEELS = (f"rosbags=={metadata.version('rosbags')}",)
PORT = 11311  # each test has a network namespace, hence a 127.0.0.1, of its own


class Ros1Error(RuntimeError):
    """A step of setting up ROS 1 failed; the message says which and why."""


def python() -> str:
    """The Python of .ros1-venv (Debian's, with its site packages), made once."""
    if not Path(DEBIAN_PYTHON).exists():
        raise Ros1Error(f"the ROS 1 tests need Debian's {DEBIAN_PYTHON} with rospy")
    return made_venv(VENV, WHEELS, scrubbed_environment(), DEBIAN_PYTHON, system_site=True)


def scrubbed_environment() -> dict[str, str]:
    """This process's variables without another Python's or ROS's."""
    foreign = ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "ROS_", "LD_LIBRARY_PATH",
               "CMAKE_PREFIX_PATH", "AMENT_PREFIX_PATH")  # fmt: skip
    return {k: v for k, v in os.environ.items() if not k.startswith(foreign)}


def environment(home: Path, port: int = PORT) -> dict[str, str]:
    """A ROS 1 process's variables: the master on loopback, logs in `home`."""
    home.mkdir(parents=True, exist_ok=True)
    return {
        **scrubbed_environment(),
        "ROS_MASTER_URI": f"http://127.0.0.1:{port}",
        "ROS_IP": "127.0.0.1",
        "ROS_HOME": str(home),
        "ROS_LOG_DIR": str(home / "log"),
        "PYTHONUNBUFFERED": "1",
        "PATH": f"{VENV / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
    }


def run(command: list[str], home: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """Run `command` isolated, with ROS 1's variables, and wait for it."""
    return subprocess.run(
        isolated(command), env=environment(home), capture_output=True, text=True,
        timeout=timeout,
    )  # fmt: skip


def start(command: list[str], home: Path, out: Path) -> subprocess.Popen[str]:
    """Start `command` isolated, with ROS 1's variables, its output to the files
    `out`.stdout and `out`.stderr (a pipe nobody reads while it runs could fill)."""
    with (
        out.with_suffix(".stdout").open("w") as stdout,
        out.with_suffix(".stderr").open("w") as stderr,
    ):  # the child keeps its own copies
        return subprocess.Popen(
            isolated(command), env=environment(home), stdout=stdout, stderr=stderr, text=True
        )
