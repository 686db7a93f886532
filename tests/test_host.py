"""The host of generated nodes (rmvdsl/host/), run with no ROS: what the monitor,
intrusion and collector nodes do, given what rclpy would hand them. The same
modules, copied into a package, run under ROS in tests/test_ros2.py."""

from __future__ import annotations

import hashlib
import http.server
import json
import socket
import socketserver
import threading
from fractions import Fraction
from typing import Any, ClassVar

import pytest
from conftest import EXAMPLES

from rmvdsl.check import check
from rmvdsl.host import collector, intrusion, monitor, status
from rmvdsl.host.actions import NodeActions
from rmvdsl.host.gaps import Gaps
from rmvdsl.ir import lower
from rmvdsl.runtime.engine import RecordingHost, Runtime, to_json

SPEC = """system host
topic twist: geometry_msgs/msg/TwistStamped = "/vehicle/twist"
var Speed = twist.twist.linear.x
event Fast when Speed > 25
event MeanSpeed = mean(Speed)
    group by time(1s)
transducer Motion {
    states Slow, Quick
    initial Slow
    Slow -> Quick on Fast
    final Quick
}
property NeverFast: not Fast {
    action publish("/rmv/alerts")
    action log("fast")
}
whitelist twist {
    publishers: "/player"
}
database {
    name = "host"
    batch_size = 3
    flush_interval = 50ms
}
"""


def _spec(tmp_path, text=SPEC):
    path = tmp_path / "host.rmv"
    path.write_text(text, encoding="utf-8")
    return lower(check(str(path)))


def _twist(speed: float) -> dict[str, Any]:
    return {"twist": {"linear": {"x": speed}}}


class Outputs:
    def __init__(self) -> None:
        self.verdicts: list[str] = []
        self.reports: list[list[status.Status]] = []
        self.warnings: list[str] = []
        self.logged: list[tuple[str, str]] = []
        self.published: list[tuple[str, str]] = []

    def verdict(self, text: str) -> None:
        self.verdicts.append(text)

    def statuses(self, statuses: list[status.Status]) -> None:
        self.reports.append(statuses)

    def warn(self, text: str) -> None:
        self.warnings.append(text)

    def log(self, level: str, text: str) -> None:
        self.logged.append((level, text))

    def actions(self) -> NodeActions:
        return NodeActions(self.log, lambda topic, text: self.published.append((topic, text)))


def test_the_monitor_hands_out_what_the_runtime_decides(tmp_path):
    """Messages taken at a clock's times, fed by the worker thread: the verdict
    segments are the runtime's on the same input, the actions ran, the statuses say
    the property's verdict and count every message."""
    spec = _spec(tmp_path)
    now = [0]
    out = Outputs()
    node = monitor.Monitor(spec, out.actions(), out, lambda: now[0], decide_period=0.01)
    node.start()
    speeds = [10.0, 30.0, 30.0, 10.0, 12.0]
    times = [10**9 + k * 10**8 for k in range(len(speeds))]
    for time, speed in zip(times, speeds, strict=True):
        now[0] = time
        node.take("/vehicle/twist", _twist(speed), {})
    node.finish()

    runtime = Runtime(spec, RecordingHost(), record=("state",))
    for time, speed in zip(times, speeds, strict=True):
        runtime.message(time, "/vehicle/twist", _twist(speed))
    runtime.end()
    expected = [to_json(status.verdict_segment(r)) for r in runtime.records()
                if r["kind"] == "verdict"]  # fmt: skip
    assert out.verdicts == expected and len(expected) == 3
    assert out.published == [("/rmv/alerts", "NeverFast violated")]
    assert out.logged == [("error", "fast")]
    last = {s.name: s for s in out.reports[-1]}
    assert last["property NeverFast"].message == "true"  # the last segment's
    assert last["monitor"].values["messages"] == "5"


def test_a_variable_a_publisher_cannot_give_is_skipped_from_then_on(tmp_path):
    """A host that finds a publisher's definition lacking a variable (`unread` in
    the message's info, from rmvdsl.host.definitions) skips it from that message on,
    as a replay skips it from the start: the monitor's runtime reads no more of it
    (no Fast from 30.0) and warns once at the variable's declaration; the collector
    neither stores nor reads it, and says so once in its log."""
    spec = _spec(tmp_path)
    unread = {"Speed": "variable `Speed` on /vehicle/twist: it is not there"}
    infos = [{}, {"unread": unread}, {"unread": unread}]
    out, now = Outputs(), [0]
    node = monitor.Monitor(spec, out.actions(), out, lambda: now[0], decide_period=0.01)
    node.start()
    for k, info in enumerate(infos):
        now[0] = 10**9 + k * 10**8
        node.take("/vehicle/twist", _twist(30.0 if k else 10.0), info)
    node.finish()
    origin = next(v.origin for v in spec.variables if v.name == "Speed")
    assert out.warnings == [f"{origin}: {unread['Speed']}"], out.warnings
    assert "false" not in "".join(out.verdicts), out.verdicts  # Speed was never 30

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Influx)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    _Influx.batches, _Influx.refuse = [], False
    out, clock = Outputs(), iter(range(10**9, 10**12, 10**8))
    stored = collector.Collector(spec, _settings(server.server_port), out, lambda: next(clock))
    stored.start()
    for k, info in enumerate(infos):
        stored.take("/vehicle/twist", _twist(30.0 if k else 10.0), info)
    stored.finish()
    server.shutdown()
    lines = [line for batch in _Influx.batches for line in batch.splitlines()]
    assert [line for line in lines if "Speed=" in line] == [lines[0]], lines
    assert "Quick" not in "".join(lines)
    assert [text for level, text in out.logged if "Speed" in text] == [unread["Speed"]]


def test_an_installed_class_unlike_the_spec_s_messages_skips_what_it_does_not_give(
    tmp_path, monkeypatch
):
    """ROS 2: the robot's installed message class and the spec's messages folder
    can disagree. The monitor judges the class it subscribes with as the replay
    judges a recording (a field of another kind, or none, skips the variable with a
    warning): a stand-in class, described as rosidl describes it (SLOT_TYPES), holds
    `x` as a string where the spec reads float64."""
    import sys
    import types

    from rmvdsl.host import ros2_definitions

    (tmp_path / "msg" / "fake_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "msg" / "fake_msgs" / "msg" / "Reading.msg").write_text(
        "float64 x\nfloat64 y\nint32[3] z\n"
    )
    spec = _spec(
        tmp_path,
        """system installed
messages "msg"
topic r: fake_msgs/msg/Reading = "/r"
var X = r.x
var Y = r.y
var Z = r.z[0]
event High when X + Y + Z > 1
property NeverHigh: not High
""",
    )

    class BasicType:
        def __init__(self, typename: str) -> None:
            self.typename = typename

    class UnboundedString:
        pass

    class Array:
        def __init__(self, value_type: Any, size: int) -> None:
            self.value_type, self.size = value_type, size

    class Reading:
        SLOT_TYPES = (UnboundedString(), BasicType("double"), Array(BasicType("int32"), 3))

        @staticmethod
        def get_fields_and_field_types() -> dict[str, str]:
            return {"x": "string", "y": "double", "z": "int32[3]"}

    monkeypatch.setitem(sys.modules, "fake_msgs", types.ModuleType("fake_msgs"))
    monkeypatch.setitem(sys.modules, "fake_msgs.msg", types.SimpleNamespace(Reading=Reading))
    (topic,) = spec.topics
    unread = ros2_definitions.unread(topic, spec.variables)
    assert unread == {"X": "variable `X` on /r: `fake_msgs/msg/Reading.x` is string in the "
                           "installed definition, the spec reads float64"}  # fmt: skip
    Reading.SLOT_TYPES = (BasicType("float"), *Reading.SLOT_TYPES[1:])
    assert ros2_definitions.unread(topic, spec.variables) == {}  # float32 reads as float64


def test_lost_messages_are_counted_from_sequence_gaps():
    gaps = Gaps()
    first = {"publication_sequence_number": 1, "publisher_gid": {"data": b"a"}}
    later = {"publication_sequence_number": 5, "publisher_gid": {"data": b"a"}}
    other = {"publication_sequence_number": 9, "publisher_gid": {"data": b"b"}}
    assert [gaps.lost("/t", first), gaps.lost("/t", later), gaps.lost("/t", other)] == [0, 3, 0]
    # 3 came after 5 (a large message on a flow of its own): found again, once
    third = {"publication_sequence_number": 3, "publisher_gid": {"data": b"a"}}
    assert [gaps.lost("/t", third), gaps.lost("/t", third), gaps.lost("/t", later)] == [-1, 0, 0]


def test_a_message_counted_lost_that_comes_later_is_counted_once(tmp_path):
    """In the monitor: read + lost stays the number published when a message comes
    after a later one."""
    spec = _spec(tmp_path)
    out = Outputs()
    node = monitor.Monitor(spec, out.actions(), out, lambda: 0)
    gid = {"data": b"a"}
    for sequence in (1, 3, 2, 4):
        info = {"publication_sequence_number": sequence, "publisher_gid": gid}
        node.feed(sequence * 10**8, "/vehicle/twist", _twist(10.0), info)
    counters = node.runtime.counters
    assert counters["messages"] == 4 and "lost messages: /vehicle/twist" not in counters
    assert counters["messages out of order: /vehicle/twist"] == 1


def test_the_intrusion_watch_waits_for_names_and_says_each_thing_once(tmp_path):
    spec = _spec(tmp_path)
    out = Outputs()
    watch = intrusion.IntrusionWatch(spec, out.actions(), own=("/rmv_intrusion",))

    def seen(*nodes: tuple[str, str]) -> list[intrusion.Seen]:
        return [intrusion.Seen("/vehicle/twist", "publisher", ns, name, name.encode())
                for ns, name in nodes]  # fmt: skip

    graph = seen(("/", "player"), ("/", "rmv_intrusion"), ("/", intrusion.UNKNOWN_NODE))
    assert watch.poll(0, graph, now=0.0) == []  # the unnamed one may yet be named
    assert watch.status().message == "no intrusion"
    lines = watch.poll(1, graph, now=intrusion.UNKNOWN_GRACE)
    assert lines == [("error", f"intrusion: /{intrusion.UNKNOWN_NODE} not in the publishers "
                               "allowed on /vehicle/twist")]  # fmt: skip
    graph += seen(("/robot", "rogue"))
    lines = watch.poll(2, graph, now=intrusion.UNKNOWN_GRACE + 1)
    assert lines == [("error", "intrusion: /robot/rogue not in the publishers allowed on "
                               "/vehicle/twist")]  # fmt: skip
    assert watch.status().message == (
        f"2 intrusions: /{intrusion.UNKNOWN_NODE} publisher /vehicle/twist, "
        "/robot/rogue publisher /vehicle/twist"
    )
    assert watch.status().level == status.ERROR
    assert sorted(watch.poll(3, seen(("/", "player")), now=10.0)) == [
        ("info", f"intrusion ended: /{intrusion.UNKNOWN_NODE} on /vehicle/twist"),
        ("info", "intrusion ended: /robot/rogue on /vehicle/twist"),
    ]
    assert watch.status().message == "no intrusion"


def test_an_unregistered_connection_is_judged_once_it_lasts_and_always_refused(tmp_path):
    """ROS 1: a connection no registration accounts for is refused whatever the
    lists say, once it has lasted UNREGISTERED_GRACE (a node that stops
    unregisters a moment before it closes its connections); a registered node
    that does not answer is stale, said once, and its endpoints are not judged."""
    spec = _spec(tmp_path)
    out = Outputs()
    watch = intrusion.IntrusionWatch(spec, out.actions(), own=(), ros_version=1)
    sneak = intrusion.Seen("/vehicle/twist", "publisher", "", "127.0.0.1:4711", b"", False)
    assert watch.poll(0, [sneak], now=0.0) == []
    grace = intrusion.UNREGISTERED_GRACE
    assert watch.poll(1, [], now=grace / 2) == []  # gone: the grace starts again
    assert watch.poll(2, [sneak], now=grace) == []
    # unseen while a node did not answer (its connections unknown): still lasting
    assert watch.poll(3, [], now=1.5 * grace, silent={"/base": intrusion.SLOW}) == []
    assert watch.poll(4, [sneak], now=2 * grace) == [
        ("error", "intrusion: 127.0.0.1:4711 publishes on /vehicle/twist without registering "
                  "with the ROS master"),
    ]  # fmt: skip
    assert watch.status().message == "1 intrusion: 127.0.0.1:4711 publisher /vehicle/twist"
    # Silent once is not stale (a node that stops may be caught between closing its
    # server and unregistering); refused for STALE_GRACE over STALE_POLLS polls is,
    # and said once.
    gone = {"/killed": intrusion.GONE}
    start = 3 * grace
    assert watch.poll(4, [sneak], now=start, silent=gone) == []
    later = start + intrusion.STALE_GRACE
    assert watch.poll(5, [sneak], now=later, silent=gone) == []  # 2 polls: the poll stalled
    lines = watch.poll(6, [sneak], now=later + 0.2, silent=gone)
    assert lines == [("warn", "stale: /killed is registered with the ROS master but does not "
                              "answer (killed?)")]  # fmt: skip
    assert watch.poll(7, [sneak], now=later + 1, silent=gone) == []
    stale = watch.statuses()[1]
    assert (stale.level, stale.message) == (
        status.WARN,
        "1 node registered but not answering: /killed",
    )
    assert watch.poll(8, [sneak], now=later + 2) == []  # it answers again: no longer stale
    assert watch.statuses()[1].level == status.OK


def test_a_node_answering_late_is_stale_only_after_the_hung_grace(tmp_path):
    """ROS 1: a call that timed out (a busy machine, a live node answering late) is
    weaker evidence than a refused one: stale only after HUNG_GRACE, said once; a
    node that answers in between starts over."""
    watch = intrusion.IntrusionWatch(_spec(tmp_path), Outputs().actions(), own=(), ros_version=1)
    slow = {"/busy": intrusion.SLOW}
    polls = [0.5 * k for k in range(int(intrusion.HUNG_GRACE / 0.5))]
    assert all(watch.poll(k, [], now=t, silent=slow) == [] for k, t in enumerate(polls))
    assert watch.poll(100, [], now=polls[-1] + 0.5) == []  # answered
    assert watch.poll(101, [], now=polls[-1] + 1, silent=slow) == []  # a new silence
    hung = polls[-1] + 1 + intrusion.HUNG_GRACE
    assert watch.poll(102, [], now=hung - 0.5, silent=slow) == []
    assert watch.poll(103, [], now=hung, silent=slow) == [
        ("warn", "stale: /busy is registered with the ROS master but has not answered for "
                 "15 s (hung?)"),
    ]  # fmt: skip
    # refused from then on (it was killed): stale already, not said again
    assert watch.poll(104, [], now=hung + 1, silent={"/busy": intrusion.GONE}) == []
    assert watch.stale == ["/busy"]


def test_ros1_messages_decode_from_the_definition_their_publisher_sent():
    """A connection header's type, md5sum and definition are all the decoder needs;
    a wrong or missing definition is a DecodeError saying why, never a crash."""
    from rosbags.highlevel import AnyReader

    from rmvdsl.host.ros1_decoding import DecodeError, Decoder

    bag = EXAMPLES / "carla" / "recordings" / "braking.bag"
    with AnyReader([bag]) as reader:
        connection = next(c for c in reader.connections if c.topic.endswith("vehicle_status"))
        raw = next(data for _, _, data in reader.messages(connections=[connection]))
    header = {"type": "carla_msgs/CarlaEgoVehicleStatus", "md5sum": connection.digest,
              "message_definition": connection.msgdef.data, "callerid": "/bridge"}  # fmt: skip
    decoder = Decoder()
    assert decoder.message_type(header) == "carla_msgs/msg/CarlaEgoVehicleStatus"
    message = decoder.decode(header, raw)
    assert message.header.stamp.sec == 1_700_000_000 and message.velocity == 20.0
    with pytest.raises(DecodeError, match="bytes"):
        decoder.decode(header, raw[:7])
    with pytest.raises(DecodeError, match="no message definition"):
        decoder.decode({**header, "md5sum": "other", "message_definition": ""}, raw)
    with pytest.raises(DecodeError, match="does not parse"):
        decoder.decode({**header, "md5sum": "x", "message_definition": "float32 ]["}, raw)


@pytest.mark.parametrize("needs", [None, {}])
def test_a_message_of_no_fields_has_an_empty_definition_and_decodes(needs):
    """std_msgs/Empty's definition is empty text, its md5sum that of nothing: a
    heartbeat topic's messages decode (they were all counted damaged: "sent no
    message definition"); an empty definition under another md5sum is refused."""
    from rmvdsl.host.ros1_decoding import EMPTY_MD5, DecodeError, Decoder

    assert hashlib.md5(b"").hexdigest() == EMPTY_MD5
    header = {"type": "std_msgs/Empty", "md5sum": EMPTY_MD5, "message_definition": ""}
    assert type(Decoder().decode(header, b"", needs)).__name__.endswith("Empty")
    with pytest.raises(DecodeError, match="no message definition"):
        Decoder().decode({**header, "md5sum": "*"}, b"", needs)


@pytest.mark.parametrize("needs", [None, {}, {"beats": None}])
def test_a_damaged_count_of_empty_messages_is_a_decode_error_however_the_topic_is_read(needs):
    """A node or a bag replay that reads a topic whole decodes with rosbags alone:
    a damaged count of 2^31 empty messages is refused as damaged (DecodeError),
    not made one by one until the machine's memory is gone."""
    from rmvdsl.host.ros1_decoding import DecodeError, Decoder

    definition = "std_msgs/Empty[] beats\nuint8 x\n" + "=" * 80 + "\nMSG: std_msgs/Empty\n"
    header = {"type": "test_msgs/Beats", "md5sum": "b", "message_definition": definition}
    damaged = (1 << 31).to_bytes(4, "little") + b"\x05"
    with pytest.raises(DecodeError, match="a count of 2147483648 messages of no bytes"):
        Decoder().decode(header, damaged, needs)
    assert len(Decoder().decode(header, (2).to_bytes(4, "little") + b"\x05", needs).beats) == 2


class _Influx(http.server.BaseHTTPRequestHandler):
    """A stand-in for InfluxDB's /write: takes every batch, or refuses it (400)."""

    batches: ClassVar[list[str]] = []
    refuse = False
    down = False  # answers 503, as an InfluxDB starting up or overloaded does

    def do_POST(self) -> None:
        body = self.rfile.read(int(self.headers["Content-Length"])).decode()
        if type(self).down:
            self.send_response(503)
            self.end_headers()
            return
        if type(self).refuse:
            self.send_response(400)
            self.end_headers()
            self.wfile.write(b'{"error":"partial write: points beyond retention dropped=2"}')
            return
        type(self).batches.append(body)
        self.send_response(204)
        self.end_headers()

    def log_message(self, *args: Any) -> None:
        pass


def _settings(port: int, **changed: Any) -> collector.Settings:
    given = {
        "url": f"http://127.0.0.1:{port}", "database": "host", "retention_policy": "autogen",
        "batch_size": 3, "flush_interval": 0.05, "timeout": 2.0, "buffer": 100,
        "username_env": "RMV_TEST_USER", "password_env": "RMV_TEST_PASSWORD",
    }  # fmt: skip
    return collector.Settings(**{**given, **changed})


def test_the_collector_writes_points_and_states_in_batches(tmp_path):
    spec = _spec(tmp_path)
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Influx)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    _Influx.batches, _Influx.refuse = [], False
    out = Outputs()
    clock = iter(range(10**9, 10**12, 10**8))
    node = collector.Collector(spec, _settings(server.server_port), out, lambda: next(clock))
    node.start()
    for speed in (10.0, 30.0, 12.0, 11.0):
        node.take("/vehicle/twist", _twist(speed), {})
    final = node.finish()
    server.shutdown()
    lines = [line for batch in _Influx.batches for line in batch.splitlines()]
    assert len(lines) == 6  # 4 messages, 2 states (Slow, then Quick)
    assert sum("Quick" in line for line in lines) == 1
    assert final.values["points written"] == "6" and final.level == status.OK
    assert all(len(batch.splitlines()) <= 3 for batch in _Influx.batches)


def test_the_collector_counts_what_influxdb_refuses(tmp_path):
    spec = _spec(tmp_path)
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Influx)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    _Influx.batches, _Influx.refuse = [], True
    out = Outputs()
    clock = iter(range(10**9, 10**12, 10**8))
    settings = _settings(server.server_port, batch_size=5)  # 4 messages, 1 state: one batch
    node = collector.Collector(spec, settings, out, lambda: next(clock))
    node.start()
    for speed in (10.0, 11.0, 12.0, 13.0):
        node.take("/vehicle/twist", _twist(speed), {})
    final = node.finish()
    server.shutdown()
    # InfluxDB says how many of the batch it dropped: the rest were written.
    assert final.values["points refused by InfluxDB"] == "2"
    assert final.values["points written"] == "3"
    assert final.level == status.WARN
    assert [level for level, _ in out.logged] == ["warn"]


def _until(condition: Any, seconds: float = 30.0) -> None:
    import time

    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def test_the_collector_spools_to_disk_while_influxdb_is_away(tmp_path):
    """InfluxDB away: 5 points wait in memory, the older go to the spool file; back,
    every point is written and the file emptied. Past the spool's bound points are
    dropped and counted; what a stopping node could not write, the next run does."""
    spec = _spec(tmp_path)
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Influx)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    _Influx.batches, _Influx.refuse, _Influx.down = [], False, True
    spool = tmp_path / "spool" / "collector.spool"
    settings = _settings(server.server_port, buffer=5, spool=str(spool), spool_bytes=10**6)
    clock = iter(range(10**9, 10**12, 10**8))
    node = collector.Collector(spec, settings, Outputs(), lambda: next(clock))
    node.start()
    for k in range(40):
        node.take("/vehicle/twist", _twist(10.0 + k % 3), {})
    waiting = node.status().values
    assert int(waiting["points spooled"]) >= 30 and "points dropped: buffer full" not in waiting
    _Influx.down = False
    _until(lambda: node.status().values.get("points written") == "41")  # and a state
    assert node.status().values["points spooled"] == "0" and spool.stat().st_size == 0
    node.finish()
    lines = [line for batch in _Influx.batches for line in batch.splitlines()]
    assert len(lines) == len(set(lines)) == 41  # each point once

    # A spool of 2,000 bytes holds some 15 points: the rest are dropped, counted.
    _Influx.batches, _Influx.down = [], True
    small = _settings(server.server_port, buffer=5, spool=str(spool), spool_bytes=2_000)
    node = collector.Collector(spec, small, Outputs(), lambda: next(clock))
    node.start()
    for k in range(60):
        node.take("/vehicle/twist", _twist(10.0 + k % 3), {})
    final = node.finish()  # InfluxDB still away: memory goes to the spool if it fits
    kept = int(final.values["points spooled"])
    dropped = int(final.values["points dropped: buffer full"])
    exit_dropped = int(final.values.get("points dropped: InfluxDB down at exit", "0"))
    assert kept >= 10 and kept + dropped + exit_dropped == 61, final.values  # 60 and a state
    # The next run writes what the last left on disk.
    _Influx.down = False
    node = collector.Collector(spec, small, Outputs(), lambda: next(clock))
    node.start()
    _until(lambda: node.status().values.get("points written") == str(kept))
    node.finish()
    server.shutdown()
    assert sum(len(b.splitlines()) for b in _Influx.batches) == kept


def test_percentiles_and_segments():
    assert status.percentiles("delay", []) == {}
    assert status.percentiles("delay", [2_000_000, 1_000_000, 3_000_000]) == {
        "delay p50 (ms)": "2.000", "delay p99 (ms)": "3.000",
    }  # fmt: skip
    record = {"kind": "verdict", "property": "P", "verdict": "unknown", "from": Fraction(1),
              "to": 2, "bounds": "[]", "revised": True, "extra": 1}  # fmt: skip
    assert json.loads(to_json(status.verdict_segment(record))) == {
        "kind": "verdict", "property": "P", "verdict": "unknown", "from": 1, "to": 2,
        "bounds": "[]", "revised": True,
    }  # fmt: skip


def test_every_example_s_spec_loads_in_the_host(tmp_path):
    """The host reads what the targets embed: each example's resolved spec runs in a
    Monitor with no input and says every property is unknown."""
    for path in (EXAMPLES / "carla" / "abs.rmv", EXAMPLES / "gazebo" / "prius_platoon.rmv"):
        spec = lower(check(str(path)))
        out = Outputs()
        node = monitor.Monitor(spec, out.actions(), out, lambda: 0)
        node.finish()
        messages = {s.name: s.message for s in out.reports[-1]}
        assert all(messages[f"property {p.name}"] == "unknown" for p in spec.properties)


def test_publishers_of_another_type_are_reported_once_and_shown_while_there():
    from rmvdsl.host.gaps import TypeWatch

    watch = TypeWatch("rmv_monitor", {"/t": "geometry_msgs/msg/TwistStamped"})
    mixed = [("/t", "/player", "geometry_msgs/msg/TwistStamped"),
             ("/t", "/imposter", "std_msgs/msg/String")]  # fmt: skip
    status, said = watch.look(mixed)
    assert (status.level, status.message) == ("warn", "std_msgs/msg/String from /imposter on /t")
    assert status.values == {"publishers of another type": "1"}
    reads = "the spec reads geometry_msgs/msg/TwistStamped"
    assert said == [f"/t: std_msgs/msg/String published by /imposter, {reads}: "
                    "its messages never reach the monitor"]  # fmt: skip
    assert watch.look(mixed)[1] == []  # said once
    status, said = watch.look(mixed[:1])
    assert (status.level, said) == ("ok", []) and status.values["publishers of another type"] == "0"


def test_the_nodes_use_their_discovery_profile_unless_told_otherwise(tmp_path, monkeypatch):
    """Fast DDS reads the package's profile (announcements every 0.25 s) unless the
    user names a profile, chooses another middleware or keeps one in the folder."""
    from rmvdsl.host.packaged import DISCOVERY_PROFILE, use_discovery_profile

    monkeypatch.chdir(tmp_path)
    environ: dict[str, str] = {}
    path = use_discovery_profile(environ)
    assert path is not None and path.endswith(DISCOVERY_PROFILE)
    assert environ == {"FASTDDS_DEFAULT_PROFILES_FILE": path}
    for chosen in ({"FASTDDS_DEFAULT_PROFILES_FILE": "mine.xml"},
                   {"FASTRTPS_DEFAULT_PROFILES_FILE": "mine.xml"},
                   {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}):  # fmt: skip
        assert use_discovery_profile(dict(chosen)) is None
    assert use_discovery_profile({"RMW_IMPLEMENTATION": "rmw_fastrtps_dynamic_cpp"})
    (tmp_path / "DEFAULT_FASTDDS_PROFILES.xml").write_text("<dds/>")
    assert use_discovery_profile({}) is None


def test_a_connection_to_a_peer_that_is_gone_waits_longer_than_a_live_sneak(tmp_path):
    """ROS 1: an inbound connection no registration accounts for is judged after
    UNREGISTERED_GRACE when its publisher's XML-RPC server answers (a live peer
    that skipped the master), after GONE_GRACE when it does not (a node that
    stopped, whose subscriber keeps retrying: the soak found it reported as a
    sneak). A stand-in master and two stand-in nodes, over real XML-RPC."""
    from rmvdsl.host import ros1_graph

    sneak = _serve({"getPid": lambda caller: [1, "", 4711]})
    with socket.socket() as probe:  # a port nothing listens on: a node that is gone
        probe.bind(("127.0.0.1", 0))
        gone = f"http://127.0.0.1:{probe.getsockname()[1]}/"
    connections = [[1, sneak, "i", "TCPROS", "/cmd", True, ""],
                   [2, gone, "i", "TCPROS", "/cmd", True, ""]]  # fmt: skip
    reader = _serve({"getBusInfo": lambda caller: [1, "", connections]})
    master = _serve({
        "getSystemState": lambda caller: [1, "", [[], [["/cmd", ["/reader"]]], []]],
        "lookupNode": lambda caller, node: [1, "", reader],
    })  # fmt: skip
    graph = ros1_graph.read(master, "/rmv_intrusion")
    found = {s.node_name: s for s in graph.unregistered}
    assert set(found) == {ros1_graph.address(sneak), ros1_graph.address(gone)}
    assert found[ros1_graph.address(sneak)].grace == intrusion.UNREGISTERED_GRACE
    assert found[ros1_graph.address(gone)].grace == intrusion.GONE_GRACE


def test_a_node_the_master_is_slow_to_look_up_is_slow_not_gone():
    """ROS 1: a registered node the master does not look up in time is not known to
    be gone (CI saw an allowed node called stale beside a loaded test run): it is
    SLOW, judged stale only after HUNG_GRACE; a node the master forgot between its
    two calls unregistered, and is not silent at all; one that refuses is GONE."""
    import time
    from xmlrpc.server import SimpleXMLRPCServer

    from rmvdsl.host import ros1_graph

    alive = _serve({"getBusInfo": lambda caller: [1, "", []]})
    with socket.socket() as probe:  # a port nothing listens on: a node that is gone
        probe.bind(("127.0.0.1", 0))
        gone = f"http://127.0.0.1:{probe.getsockname()[1]}/"

    def lookup(caller: str, node: str) -> list:
        if node == "/busy":
            time.sleep(0.6)
        if node == "/left":
            return [-1, "unknown node [/left]", ""]
        return [1, "", gone if node == "/dead" else alive]

    nodes = ["/alive", "/busy", "/dead", "/left"]
    master = _serve(
        {
            "getSystemState": lambda caller: [1, "", [[["/cmd", nodes]], [], []]],
            "lookupNode": lookup,
        },
        server=type("Threaded", (socketserver.ThreadingMixIn, SimpleXMLRPCServer), {}),
    )
    graph = ros1_graph.read(master, "/rmv_intrusion", timeout=0.3)
    assert graph.silent == {"/busy": intrusion.SLOW, "/dead": intrusion.GONE}
    assert {s.node_name for s in graph.registered} == {n.lstrip("/") for n in nodes}


def test_a_departed_endpoint_s_connection_is_still_that_endpoint():
    """ROS 1: the soak found a publisher that never writes keeping a connection to
    a subscriber that had left, and subscribers retrying a publisher that had
    stopped, each reported as skipping the master. A connection of an endpoint the
    master listed in an earlier poll is that endpoint still, by its name, while it
    lasts (an allowed one stays allowed, a refused one refused); one the master
    never listed is a peer that skipped it."""
    from rmvdsl.host import ros1_graph

    talker = _serve({"getPid": lambda caller: [1, "", 1]})  # a publisher that left
    quiet_connections = [[1, "/listener", "o", "TCPROS", "/cmd", True, ""]]
    reader_connections = [[2, talker, "i", "TCPROS", "/cmd", True, ""]]
    quiet = _serve({"getBusInfo": lambda caller: [1, "", quiet_connections]})
    reader = _serve({"getBusInfo": lambda caller: [1, "", reader_connections]})
    uris = {"/quiet": quiet, "/reader": reader, "/talker": talker, "/listener": quiet}
    listed = [[["/cmd", ["/quiet", "/talker"]]], [["/cmd", ["/reader", "/listener"]]], []]
    left = [[["/cmd", ["/quiet"]]], [["/cmd", ["/reader"]]], []]
    state = list(listed)
    master = _serve({
        "getSystemState": lambda caller: [1, "", state],
        "lookupNode": lambda caller, node: [1, "", uris[node]] if node in uris
                                           else [-1, "unknown node", ""],
    })  # fmt: skip

    def endpoints(graph: ros1_graph.Graph) -> set[tuple[str, str, bool]]:
        return {(s.node, s.role, s.registered) for s in graph.registered + graph.unregistered}

    graph = ros1_graph.Reader(master, "/rmv_intrusion")
    everyone = endpoints(graph.read())
    assert ("/talker", "publisher", True) in everyone and (
        "/listener",
        "subscriber",
        True,
    ) in everyone
    state[:] = left  # talker and listener left; their connections linger
    assert endpoints(graph.read()) == everyone
    assert endpoints(graph.read()) == everyone
    reader_connections.clear()  # the talker's connection ends: the talker is gone
    assert ("/talker", "publisher", True) not in endpoints(graph.read())
    never = ros1_graph.Reader(master, "/rmv_intrusion").read()
    assert {(s.node, s.role) for s in never.unregistered} == {("/listener", "subscriber")}


def _serve(functions: dict, server: type | None = None) -> str:
    """An XML-RPC server on loopback answering `functions` (a stand-in ROS 1 master
    or node), in a thread of its own; its URI. `server`: the class, if not
    SimpleXMLRPCServer (one that answers calls at once, say)."""
    from xmlrpc.server import SimpleXMLRPCServer

    server = (server or SimpleXMLRPCServer)(("127.0.0.1", 0), logRequests=False, allow_none=True)
    for name, function in functions.items():
        server.register_function(function, name)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return f"http://127.0.0.1:{server.server_address[1]}/"
