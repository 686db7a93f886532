"""The replay's second process (rmvdsl.tools.read_ahead; docs/replay.md, "Two
processes"): reading, decoding and taking readings in a forked child gives exactly
what one process gives — the same records in the same order — on every storage,
window, stamped topic, lateness, damaged message, unreadable tail and random spec;
and a child that fails, dies or is left behind is said, never hung on."""

from __future__ import annotations

import json
import os
import random
import shutil
import struct
from pathlib import Path
from typing import Any

import differential
import fleet_recordings
import pytest
from conftest import EXAMPLES, damaged_bag

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime.engine import to_json
from rmvdsl.tools import read_ahead
from rmvdsl.tools.recordings import ReplayError
from rmvdsl.tools.replay import replay

CARLA = EXAMPLES / "carla"
RECORDINGS = [CARLA / "recordings" / n for n in ("braking.bag", "braking_db3", "braking_mcap")]


def _both(spec: Any, path: Path | list[Path], **options: Any) -> list[str]:
    """The records of one process, having asserted the child's are the same."""
    paths = path if isinstance(path, list) else [path]
    alone = [to_json(r) for r in replay(spec, paths, **options)]
    ahead = [to_json(r) for r in replay(spec, paths, in_a_child=True, **options)]
    assert ahead == alone, (paths, options)
    return alone


def _children() -> set[int]:
    """This process's living children, over all its threads."""
    found: set[int] = set()
    for task in Path(f"/proc/{os.getpid()}/task").iterdir():
        text = (task / "children").read_text(encoding="ascii")
        found.update(int(pid) for pid in text.split())
    return found


@pytest.fixture(scope="module")
def carla_spec() -> Any:
    return lower(check(str(CARLA / "abs.rmv")))


@pytest.mark.parametrize("path", RECORDINGS, ids=lambda p: p.name)
def test_each_storage_whole_and_windowed(carla_spec, path):
    records = _both(carla_spec, path, record=("state", "event", "variable"))
    assert sum(r.startswith('{"kind": "verdict"') for r in records) >= 6
    _both(carla_spec, path, start="+5", stop="+21.5")


def test_stamped_topics_held_by_lateness(tmp_path):
    """`time = header` on both topics and a lateness: readings carry the stamps,
    and held messages keep their readings until they are ordered in."""
    text = (CARLA / "abs.rmv").read_text(encoding="utf-8")
    text = text.replace('messages "msg"', f'messages "{CARLA / "msg"}"')
    text = text.replace("    reliability = reliable\n",
                        "    reliability = reliable\n    time = header\n")  # fmt: skip
    objects = '"/carla/hero/objects"\n'
    text = text.replace(objects, objects[:-1] + " qos { time = header }\n")
    text = text.replace("    window = 75s\n", "    window = 75s\n    lateness = 300ms\n")
    source = tmp_path / "stamped.rmv"
    source.write_text(text, encoding="utf-8")
    records = _both(lower(check(str(source))), RECORDINGS[0])
    assert any('"kind": "state"' in r for r in records)


def test_damaged_messages_and_a_rogue_publisher(carla_spec, tmp_path):
    path = tmp_path / "damaged.bag"
    damaged_bag(path)
    records = _both(carla_spec, path)
    assert any("a message cannot be decoded" in r for r in records)
    assert any('"kind": "intrusion"' in r for r in records)
    merged = _both(carla_spec, [RECORDINGS[0], path])  # one run over both, in time order
    assert sum('"name": "messages", "value": ' in r for r in merged) == 1


def test_messages_of_one_time_in_merged_recordings_come_in_the_order_given(carla_spec, tmp_path):
    """At 0.15 s both recordings hold a status message, the damaged bag's cut
    short: the recording given first gives its message first, in every run
    (rosbags orders them by where its readers lie in memory)."""
    damaged = tmp_path / "damaged.bag"
    damaged_bag(damaged)

    def first_at_015(paths: list[Path]) -> str:
        records = _both(carla_spec, paths, record=("variable",))
        return next(json.loads(r)["kind"] for r in records if '"time": 1700000000.15,' in r)

    assert first_at_015([RECORDINGS[0], damaged]) == "variable"
    assert first_at_015([damaged, RECORDINGS[0]]) == "diagnostic"


def test_a_spec_none_of_whose_topics_the_recording_holds(tmp_path):
    """Nothing to read: no message is read (rosbags reads every message when
    given no connection), and the run says what is missing."""
    records = _both(lower(check(str(EXAMPLES / "gazebo" / "network.rmv"))), RECORDINGS[2])
    assert any("is not in the recording" in r for r in records)
    assert not any('"name": "messages"' in r for r in records)  # none was fed


def test_recordings_that_cannot_be_read_past_a_point(tmp_path):
    """Flipped bytes: damaged messages, a tail that cannot be read, or a recording
    that lists more than it gives; each said alike by both."""
    spec_path = tmp_path / "twist.rmv"
    spec_path.write_text(fleet_recordings.SPEC, encoding="utf-8")
    spec = lower(check(str(spec_path)))
    good = fleet_recordings.write(tmp_path / "good", "mcap", fleet_recordings.speeds(1, 600))
    data = next(good.glob("*.mcap"))
    size = data.stat().st_size
    rng = random.Random(37)  # reaches a lost message and an unreadable tail
    said: set[str] = set()
    for index in range(40):
        target = tmp_path / f"flip{index}_mcap"
        shutil.copytree(good, target)
        damaged = bytearray(data.read_bytes())
        damaged[rng.randrange(size)] ^= 0xFF
        (target / data.name).write_bytes(bytes(damaged))
        try:
            records = _both(spec, target)
        except ReplayError:
            continue  # its summary is damaged: nothing is read, by either
        said.update(r for r in records if '"kind": "diagnostic"' in r)
    assert said, "the flips should reach damage the replay reports"


def _cut_short_at(recording: Path, message: int) -> None:
    """The MCAP file's `message`th message record (counted from 0) claims more
    bytes than the file holds: none from it on can be read. Found through the
    summary's chunk index (the writer's one chunk, uncompressed)."""
    path = next(recording.glob("*.mcap"))
    data = bytearray(path.read_bytes())

    def u64(at: int) -> int:
        return int(struct.unpack_from("<Q", data, at)[0])

    footer = len(data) - 8 - (1 + 8 + 8 + 8 + 4)  # the footer record, then the magic
    assert data[footer] == 0x02
    position = u64(footer + 9)  # the summary's start
    while data[position] != 0x08:  # a chunk index record
        position += 9 + u64(position + 1)
    chunk = u64(position + 9 + 16)
    assert data[chunk] == 0x06
    compression = chunk + 9 + 8 + 8 + 8 + 4  # its times, size and CRC, then this
    assert struct.unpack_from("<I", data, compression)[0] == 0, "uncompressed"
    record = compression + 4 + 8  # past the records' length
    for _ in range(message + 1):
        while data[record] != 0x05:  # schemas and channels come first
            record += 9 + u64(record + 1)
        found, record = record, record + 9 + u64(record + 1)
    struct.pack_into("<Q", data, found + 1, 2**40)
    path.write_bytes(bytes(data))


def test_a_recording_that_cannot_be_read_past_a_message(tmp_path):
    """The runtime hears where: the last time read (rosbags reads a chunk whole
    before giving its first message, so here the recording's start), the rest not
    checked."""
    spec_path = tmp_path / "twist.rmv"
    spec_path.write_text(fleet_recordings.SPEC, encoding="utf-8")
    recording = fleet_recordings.write(tmp_path / "cut", "mcap", fleet_recordings.speeds(2, 90))
    _cut_short_at(recording, 40)
    records = _both(lower(check(str(spec_path))), recording)
    said = [r for r in records if "the recording cannot be read past" in r]
    assert len(said) == 1 and "past 1700000000: Truncated record" in said[0], said
    assert "the rest of it is not checked" in said[0]


def test_random_specs_and_recordings(tmp_path):
    rng = random.Random(20261202)
    compared = 0
    for seed in range(9):
        case = differential.make_case(seed)
        spec = differential.runnable_spec(case, tmp_path)
        if spec is None:
            continue
        messages = differential.make_recording(rng, case.topics)
        kind = ("mcap", "db3", "bag")[seed % 3]
        path = differential.write_recording(tmp_path / f"case{seed}", kind, messages, case.topics)
        _both(spec, path, record=("state", "event", "variable"))
        compared += 1
    assert compared >= 6


def test_a_run_stopped_early_leaves_no_process(carla_spec):
    before = _children()
    records = replay(carla_spec, [RECORDINGS[2]], in_a_child=True)
    next(records)
    assert len(_children() - before) == 1  # the reader, running
    records.close()
    assert _children() == before


def _failing(after: int, how: str) -> Any:
    """`readings` whose child fails after `after` items: by an exception, or killed."""
    original = read_ahead.readings

    def readings(*args: Any, **kwargs: Any) -> Any:
        for count, item in enumerate(original(*args, **kwargs)):
            if count == after:
                if how == "raises":
                    raise RuntimeError("the disk went away")
                os.kill(os.getpid(), 9)
            yield item

    return readings


@pytest.mark.parametrize(
    ("how", "says"),
    [
        ("raises", "the recording's reader failed: RuntimeError: the disk went away"),
        ("killed", "the recording's reader process ended before the recording did"),
    ],
)
def test_a_child_that_fails_is_said_not_waited_for(carla_spec, monkeypatch, how, says):
    monkeypatch.setattr(read_ahead, "readings", _failing(100, how))
    before = _children()
    with pytest.raises(ReplayError, match=says):
        list(replay(carla_spec, [RECORDINGS[0]], in_a_child=True))
    assert _children() == before


def test_the_command_says_a_failing_child_in_words(rmv, monkeypatch):
    monkeypatch.setattr(read_ahead, "usable", lambda: True)
    monkeypatch.setattr(read_ahead, "readings", _failing(10, "raises"))
    result = rmv("replay", str(CARLA / "abs.rmv"), str(RECORDINGS[1]))
    assert result.code == 2, result.err
    assert "the recording's reader failed: RuntimeError: the disk went away" in result.err
    assert "Traceback" not in result.err


SKIPPED = """system skipped
topic t: std_msgs/msg/Float64 = "/t"
var x = t.data
var y = t.data
event High when y > 5
property Low: not High {
    lateness = 500ms
}
"""


@pytest.mark.parametrize("skip", [False, True])
def test_a_variable_a_live_host_skips_is_not_read_from_then_on(tmp_path, skip):
    """`Runtime.skip` (a live publisher's definition lacks the field): readings
    taken before, and held by the lateness, still line up with their variables;
    the skipped one gives no value from then on, its neighbour every value."""
    from rmvdsl.runtime.engine import Runtime

    source = tmp_path / "skipped.rmv"
    source.write_text(SKIPPED, encoding="utf-8")
    runtime = Runtime(lower(check(str(source))), record=("variable",))
    runtime.message(0, "/t", {"data": 1.0})
    runtime.message(200_000_000, "/t", {"data": 7.0})  # held: within the lateness
    if skip:
        runtime.skip(300_000_000, "/t", {"x": "x cannot be read"})
        runtime.skip(400_000_000, "/t", {"x": "x cannot be read"})  # said once
    runtime.message(10**9, "/t", {"data": 9.0})
    runtime.end()
    records = runtime.records()
    values = {name: [r["value"] for r in records if r["kind"] == "variable" and r["name"] == name]
              for name in ("x", "y")}  # fmt: skip
    assert values["y"] == [1.0, 7.0, 9.0]
    assert values["x"] == ([] if skip else [1.0, 7.0, 9.0])
    said = [r["message"] for r in records if r["kind"] == "diagnostic"]
    assert said == (["x cannot be read"] if skip else [])


def test_where_no_process_can_be_made_the_replay_reads_in_line(carla_spec, monkeypatch):
    def refused() -> int:
        raise BlockingIOError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(os, "fork", refused)
    alone = [to_json(r) for r in replay(carla_spec, [RECORDINGS[1]])]
    assert [to_json(r) for r in replay(carla_spec, [RECORDINGS[1]], in_a_child=True)] == alone
