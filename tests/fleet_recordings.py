"""Small recordings made with rosbags, for the fleet tests and benchmark: a robot's
speed on /vehicle/twist as ROS 1 .bag files, ROS 2 .db3 and .mcap recordings. A
run's speeds come from its seed: most runs pass, some stop (NeverStops), some go
fast for long (NotFastLong)."""

from __future__ import annotations

import random
from pathlib import Path
from typing import Any

from rosbags.rosbag1 import Writer as Bag1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Bag2Writer
from rosbags.typesys import Stores, get_typestore

SPEC = """system fleet_twist "a robot's speed, over many runs"
time unit s
topic twist: geometry_msgs/msg/TwistStamped = "/vehicle/twist"
var Speed = twist.twist.linear.x
event Fast when Speed > 25
event Stopped when Speed < 0.1
/// Fast for less than 2 s of every 4 s.
property NotFastLong: duration[4s](Fast) < 2s
property NeverStops: not Stopped
"""
TOPIC = "/vehicle/twist"
TWIST = "geometry_msgs/msg/TwistStamped"
KINDS = ("bag", "db3", "mcap")
START = 1_700_000_000 * 10**9


def speeds(seed: int, count: int) -> list[float]:
    """A run's speeds: cruising, with now and then a stop or a long fast stretch."""
    rng = random.Random(seed)
    out = [rng.uniform(5, 20) for _ in range(count)]
    trouble = rng.random()
    if trouble < 0.15:
        at = rng.randrange(count)
        out[at] = 0.0
    elif trouble < 0.3:
        at = rng.randrange(max(1, count - 30))
        out[at : at + 30] = [30.0] * len(out[at : at + 30])
    return out


def _twist(store: Any, t: int, speed: float, ros1: bool) -> Any:
    types = store.types
    stamp = types["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9)
    if ros1:
        header = types["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="")
    else:
        header = types["std_msgs/msg/Header"](stamp=stamp, frame_id="")
    vector = types["geometry_msgs/msg/Vector3"]
    twist = types["geometry_msgs/msg/Twist"](linear=vector(x=speed, y=0.0, z=0.0),
                                             angular=vector(x=0.0, y=0.0, z=0.0))  # fmt: skip
    return types[TWIST](header=header, twist=twist)


def write(path: Path, kind: str, values: list[float], step_ns: int = 100_000_000) -> Path:
    """A recording of `values`, one message each `step_ns`: `path` plus its suffix."""
    if kind == "bag":
        store = get_typestore(Stores.ROS1_NOETIC)
        target = path.with_suffix(".bag")
        with Bag1Writer(target) as writer:
            connection = writer.add_connection(TOPIC, TWIST, typestore=store, callerid="/player")
            for i, value in enumerate(values):
                t = START + i * step_ns
                data = store.serialize_ros1(_twist(store, t, value, True), TWIST)
                writer.write(connection, t, data)
        return target
    store = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.SQLITE3 if kind == "db3" else StoragePlugin.MCAP
    target = path.with_name(f"{path.name}_{kind}")
    with Bag2Writer(target, version=9, storage_plugin=plugin) as writer:
        connection = writer.add_connection(TOPIC, TWIST, typestore=store)
        for i, value in enumerate(values):
            t = START + i * step_ns
            writer.write(connection, t, store.serialize_cdr(_twist(store, t, value, False), TWIST))
    return target


def fleet(folder: Path, count: int, messages: int = 40, seed: int = 0) -> list[Path]:
    """`count` recordings in `folder`, the three formats in turn."""
    folder.mkdir(parents=True, exist_ok=True)
    return [
        write(folder / f"run{index:04d}", KINDS[index % 3], speeds(seed + index, messages))
        for index in range(count)
    ]


def sent_bag(path: Path, sent: list[list[float]]) -> Path:
    """What a soak sent (stamp, speed), 20 a second from START, as a ROS 1 bag logged
    at the stamps (tests/ros1/drive_soak.py)."""
    step = 10**9 // 20
    assert [int(stamp) for stamp, _ in sent] == [START + k * step for k in range(len(sent))]
    return write(path, "bag", [speed for _, speed in sent], step_ns=step)
