"""Inside the private network namespace (run by the .ros1-venv Python): a ROS 1
master and rosout of their own, and processes started and stopped by PID."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

ROSOUT = "/usr/lib/rosout/rosout"


def master_uri() -> str:
    return os.environ["ROS_MASTER_URI"]


def wait_for(condition, timeout: float, what: str, step: float = 0.05) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(step)
    raise TimeoutError(f"{what}: not within {timeout} s")


def system_state() -> tuple[list, list, list]:
    code, text, state = xmlrpc.client.ServerProxy(master_uri()).getSystemState("/test")
    assert code == 1, text
    return tuple(state)


def set_param(name: str, value: object) -> None:
    code, text, _ = xmlrpc.client.ServerProxy(master_uri()).setParam("/test", name, value)
    assert code == 1, text


def _master_answers() -> bool:
    try:
        system_state()
        return True
    except OSError:
        return False


def publishes(node: str, topic: str) -> bool:
    return any(t == topic and node in nodes for t, nodes in system_state()[0])


def subscribes(node: str, topic: str) -> bool:
    return any(t == topic and node in nodes for t, nodes in system_state()[1])


def start(command: list[str], log: Path) -> subprocess.Popen:
    handle = log.open("w")
    return subprocess.Popen(
        command, stdout=handle, stderr=subprocess.STDOUT, start_new_session=True
    )


def stop(process: subprocess.Popen, signal_number: int = signal.SIGINT, timeout: float = 15) -> int:
    if process.poll() is None:
        process.send_signal(signal_number)
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            # an rmvdsl node writes each thread's stack to its log: the hang shows
            process.send_signal(signal.SIGUSR1)
            time.sleep(2.0)
            process.kill()
            process.wait()
    return process.returncode


@contextmanager
def roscore(logs: Path) -> Iterator[None]:
    """rosmaster --core and rosout, stopped (SIGTERM: rosmaster ignores SIGINT's
    polite form for long) when the block ends."""
    port = master_uri().rsplit(":", 1)[1]
    master = start(["rosmaster", "--core", "-p", port], logs / "rosmaster.log")
    rosout = None
    try:
        wait_for(_master_answers, 10, "rosmaster")
        rosout = start([ROSOUT, "__name:=rosout"], logs / "rosout.log")
        wait_for(lambda: publishes("/rosout", "/rosout_agg"), 10, "rosout")
        yield
    finally:
        if rosout is not None:
            stop(rosout, signal.SIGTERM)
        stop(master, signal.SIGTERM)


def python() -> str:
    return sys.executable
