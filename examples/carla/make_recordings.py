"""Write the CARLA braking recordings of the README's tour with rosbags' writers.

    python examples/carla/make_recordings.py [OUT_DIR]

30 s of the ego vehicle at 20 Hz and of the objects around it at 10 Hz, as ROS 1
`braking.bag` (with the bridge as each connection's caller id) and ROS 2
`braking.mcap` and `braking.db3`, the same messages in each:

- 0-10 s cruising at 20 m/s; at 10 s a hard brake at 8 m/s^2: stopped at 12.5 s
  (ABSCheck holds: 2.4 s of hard braking, ending in a stop);
- 13-17 s accelerating to 30 m/s; at 18 s a hard brake at 6 m/s^2: 5 s of hard
  braking before the stop at 23 s, more than the 4 s ABSCheck allows: the one
  known violation, from 18.1 s (the first 100 ms window whose derivative is below
  -5 m/s^2).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.rosbag1 import Writer as Bag1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Bag2Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

HERE = Path(__file__).resolve().parent
START = 1_700_000_000 * 10**9  # 2023-11-14 22:13:20 UTC: 20 s into a minute
STATUS, OBJECTS = "/carla/hero/vehicle_status", "/carla/hero/objects"
STATUS_TYPE = "carla_msgs/msg/CarlaEgoVehicleStatus"
OBJECTS_TYPE = "derived_object_msgs/msg/ObjectArray"
BRIDGE = "/carla_ros_bridge"


def typestore(store_kind: Stores) -> Any:
    store = get_typestore(store_kind)
    types: dict[str, Any] = {}
    for path in sorted((HERE / "msg").glob("*/msg/*.msg")):
        name = f"{path.parent.parent.name}/msg/{path.stem}"
        types.update(get_types_from_msg(path.read_text(encoding="utf-8"), name))
    store.register(types)
    return store


def default(store: Any, msgtype: str) -> Any:
    """A message with every field zero, empty or default."""
    cls = store.types[msgtype]
    values = {name: _default_field(store, kind) for name, kind in store.fielddefs[msgtype][1]}
    return cls(**values)


def _default_field(store: Any, kind: tuple[Any, Any]) -> Any:
    import numpy

    node, detail = kind
    if node == Nodetype.NAME:
        return default(store, detail)
    if node == Nodetype.BASE:
        base = detail[0]
        if base == "string":
            return ""
        if base == "bool":
            return False
        return 0.0 if base.startswith("float") else 0
    if node == Nodetype.ARRAY:
        inner, count = detail
        if inner[0] == Nodetype.BASE and inner[1][0] != "string":
            dtype = "float64" if inner[1][0].startswith("float") else "int64"
            dtype = {"float32": "float32", "uint8": "uint8", "int8": "int8"}.get(inner[1][0], dtype)
            return numpy.zeros(count, dtype=dtype)
        return [_default_field(store, inner) for _ in range(count)]
    return [] if node != Nodetype.SEQUENCE or detail[0][0] != Nodetype.BASE else numpy_empty(detail)


def numpy_empty(detail: Any) -> Any:
    import numpy

    base = detail[0][1][0]
    if base == "string":
        return []
    return numpy.zeros(0, dtype="float64" if base.startswith("float") else "uint8")


def velocity_at(t: float) -> tuple[float, float, float]:
    """Speed (m/s), brake and throttle at t seconds into the scenario."""
    if t < 10:
        return 20.0, 0.0, 0.5
    if t < 12.5:
        return 20.0 - 8.0 * (t - 10), 1.0, 0.0
    if t < 13:
        return 0.0, 0.3, 0.0
    if t < 18:
        return min(30.0, 6.0 * (t - 13)), 0.0, 0.8
    if t < 23:
        return 30.0 - 6.0 * (t - 18), 1.0, 0.0
    return 0.0, 0.3, 0.0


def messages(store: Any) -> list[tuple[int, str, Any]]:
    out: list[tuple[int, str, Any]] = []
    for k in range(600):  # 20 Hz for 30 s
        t = START + k * 50_000_000
        status = default(store, STATUS_TYPE)
        speed, brake, throttle = velocity_at(k / 20)
        status.velocity = speed
        status.control.brake = brake
        status.control.throttle = throttle
        status.header.stamp.sec, status.header.stamp.nanosec = divmod(t, 10**9)
        out.append((t, STATUS, status))
    for k in range(300):  # 10 Hz
        t = START + k * 100_000_000 + 25_000_000
        array = default(store, OBJECTS_TYPE)
        array.header.stamp.sec, array.header.stamp.nanosec = divmod(t, 10**9)
        for i in range(3):
            item = default(store, "derived_object_msgs/msg/Object")
            item.id = i
            item.twist.linear.x = 5.0 * i + (k % 10) * 0.5
            array.objects.append(item)
        out.append((t, OBJECTS, array))
    out.sort(key=lambda m: m[0])
    return out


def write_bag(path: Path) -> None:
    store = typestore(Stores.ROS1_NOETIC)
    path.unlink(missing_ok=True)
    with Bag1Writer(path) as writer:
        connections = {
            topic: writer.add_connection(topic, kind, typestore=store, callerid=BRIDGE)
            for topic, kind in ((STATUS, STATUS_TYPE), (OBJECTS, OBJECTS_TYPE))
        }
        for t, topic, message in messages(store):
            data = store.serialize_ros1(message, message.__msgtype__)
            writer.write(connections[topic], t, data)


def write_bag2(path: Path, plugin: StoragePlugin) -> None:
    import shutil

    store = typestore(Stores.ROS2_HUMBLE)
    shutil.rmtree(path, ignore_errors=True)
    with Bag2Writer(path, version=9, storage_plugin=plugin) as writer:
        connections = {
            topic: writer.add_connection(topic, kind, typestore=store)
            for topic, kind in ((STATUS, STATUS_TYPE), (OBJECTS, OBJECTS_TYPE))
        }
        for t, topic, message in messages(store):
            writer.write(connections[topic], t, store.serialize_cdr(message, message.__msgtype__))


def main(argv: list[str]) -> int:
    out = Path(argv[1]) if len(argv) > 1 else HERE / "recordings"
    out.mkdir(parents=True, exist_ok=True)
    write_bag(out / "braking.bag")
    write_bag2(out / "braking_mcap", StoragePlugin.MCAP)
    write_bag2(out / "braking_db3", StoragePlugin.SQLITE3)
    for path in sorted(out.rglob("*")):
        if path.is_file():
            print(f"{path}: {path.stat().st_size:,} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
