"""The replay's second process (rmvdsl.tools.read_ahead; docs/replay.md, "Two
processes"): reading, decoding and taking readings in a forked child gives exactly
what one process gives — the same records in the same order — on every storage,
window, stamped topic, lateness, damaged message, unreadable tail and random spec;
and a child that fails, dies or is left behind is said, never hung on."""

from __future__ import annotations

import dataclasses
import os
import random
import shutil
from pathlib import Path
from typing import Any

import differential
import fleet_recordings
import pytest
from conftest import EXAMPLES, damaged_bag
from test_chunks import _write

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime.engine import to_json
from rmvdsl.tools import read_ahead
from rmvdsl.tools.recordings import ReplayError
from rmvdsl.tools.replay import replay

CARLA = EXAMPLES / "carla"
RECORDINGS = [CARLA / "recordings" / n for n in ("braking.bag", "braking_db3", "braking_mcap")]


def _both(spec: Any, path: Path, **options: Any) -> list[str]:
    """The records of one process, having asserted the child's are the same."""
    alone = [to_json(r) for r in replay(spec, [path], **options)]
    ahead = [to_json(r) for r in replay(spec, [path], in_a_child=True, **options)]
    assert ahead == alone, (path, options)
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


def test_random_specs_and_recordings(tmp_path):
    rng = random.Random(20261202)
    compared = 0
    for seed in range(9):
        case = differential.make_case(seed)
        result = differential.check_case(case, tmp_path)
        if any(e.code not in differential.ANALYSIS_ERRORS for e in result.errors):
            continue
        kept = [d for d in result.diagnostics if d.code not in differential.ANALYSIS_ERRORS]
        spec = lower(dataclasses.replace(result, diagnostics=kept))
        messages = differential.make_recording(rng, case.topics)
        kind = ("mcap", "db3", "bag")[seed % 3]
        path = _write(tmp_path / f"case{seed}", kind, messages, case.topics)
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
