"""No silent pass (issue 36): a replay whose result cannot be trusted says so and
exits 2 — a window that holds no message, a recording that gives fewer messages
than it lists (a flipped byte), one that cannot be read past a point — and a
window that is empty or not a time is a usage error, in the user's words."""

from __future__ import annotations

import json
import random
import shutil
from pathlib import Path

import fleet_recordings
import pytest
from conftest import EXAMPLES

SPEC = EXAMPLES / "carla" / "abs.rmv"
BAG = EXAMPLES / "carla" / "recordings" / "braking.bag"


@pytest.mark.parametrize(
    ("window", "says"),
    [
        (["--from", "+50"], "the window --from +50 holds no message of the topics the spec reads"),
        (["--to", "1000"], "the window --to 1000 holds no message of the topics the spec reads"),
    ],
)
def test_a_window_that_holds_no_message_is_not_a_pass(rmv, window, says):
    result = rmv("replay", str(SPEC), str(BAG), *window)
    assert result.code == 2, result.out
    assert says in result.out and result.out.rstrip().endswith("1 warning about the recording")


@pytest.mark.parametrize(
    ("window", "says"),
    [
        (["--from", "+10", "--to", "+5"], "--from +10 --to +5: the window is empty"),
        (["--from", "1700000010", "--to", "+5"], "the window is empty"),
        (["--to", "-5"], "argument --to: -5: give seconds on the recording's clock"),
        (["--from", "1e400"], "argument --from: 1e400: give seconds"),
        (
            ["--from", "abc"],
            "argument --from: abc: give seconds on the recording's clock "
            "(1700000012.5) or after its start (+12.5)",
        ),
    ],
)
def test_a_window_that_is_empty_or_not_a_time_is_a_usage_error(rmv, window, says):
    result = rmv("replay", str(SPEC), str(BAG), *window)
    assert result.code == 2 and says in result.err, result.err
    assert "Fraction" not in result.err


@pytest.fixture(scope="module")
def twist(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("flips")
    recording = fleet_recordings.write(folder / "good", "mcap", fleet_recordings.speeds(1, 600))
    spec = folder / "spec.rmv"
    spec.write_text(fleet_recordings.SPEC, encoding="utf-8")
    return spec, recording


def _flipped(source: Path, target: Path, position: int) -> Path:
    shutil.copytree(source, target)
    data = next(target.glob("*.mcap"))
    damaged = bytearray(data.read_bytes())
    damaged[position] ^= 0xFF
    data.write_bytes(bytes(damaged))
    return target


def test_flipped_bytes_never_pass_silently_nor_crash(rmv, twist, tmp_path):
    """One byte flipped at each of 40 places of a 600-message .mcap: every replay
    ends (no traceback); one that read fewer messages than the recording lists says
    how many were lost and exits 2; none that lost messages passes."""
    spec, good = twist
    size = next(good.glob("*.mcap")).stat().st_size
    rng = random.Random(36)
    short = 0
    for index in range(40):
        target = _flipped(good, tmp_path / f"flip{index}_mcap", rng.randrange(size))
        result = rmv("replay", str(spec), str(target), "--format", "jsonl")
        assert result.code in (0, 1, 2) and "internal error" not in result.err, result.err
        if result.code == 2 and not result.out:
            assert "cannot read the recording" in result.err  # the summary itself is damaged
            continue
        records = [json.loads(line) for line in result.out.splitlines()]
        counters = {r["name"]: r["value"] for r in records if r["kind"] == "counter"}
        lost = counters.get("messages the recording lists but cannot be read", 0)
        damaged = counters.get("damaged messages: /vehicle/twist", 0)
        assert counters.get("messages", 0) + lost + damaged >= 600 or result.code == 2
        if lost:
            short += 1
            assert result.code == 2
            said = [r["message"] for r in records if r["kind"] == "diagnostic"]
            assert any(f"the recording lists 600 messages on the topics the spec reads, and "
                       f"{600 - lost} could be read" in s for s in said), said  # fmt: skip
    assert short >= 1, short  # the flips reach the case


FAILING = """system failing
topic t: std_msgs/msg/Float64 = "/t"
var x = t.data
event High when x > 5
property Low: not High {{
    action exec("{missing}", ["--now", "a b"])
    action exec("{python}", ["-c", "raise SystemExit(3)"])
    action tcp("127.0.0.1:{port}")
    action post("http://127.0.0.1:{port}/hook", timeout = 2s)
    action log("x went high")
}}
"""


def test_actions_that_fail_say_so_in_every_format(rmv, tmp_path):
    """--run-actions: a missing program, a program that exits 3, a tcp and a post
    to a port nothing listens on: each action's line names what it ran and how it
    failed, in words; the summary counts them; jsonl has the same words."""
    import socket
    import sys

    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    spec = tmp_path / "failing.rmv"
    spec.write_text(FAILING.format(missing=tmp_path / "no-such-program", python=sys.executable,
                                   port=port), encoding="utf-8")  # fmt: skip
    store = get_typestore(Stores.ROS2_HUMBLE)
    recording = tmp_path / "values"
    with Writer(recording, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/t", "std_msgs/msg/Float64", typestore=store)
        for k, value in enumerate([1.0, 7.0, 1.0]):
            data = store.serialize_cdr(store.types["std_msgs/msg/Float64"](value),
                                       "std_msgs/msg/Float64")  # fmt: skip
            writer.write(connection, 10**9 * (1000 + k), data)
    text = rmv("replay", str(spec), str(recording), "--run-actions")
    assert text.code == 1, text.err
    lines = [line for line in text.out.splitlines() if line.startswith("action")]
    missing = tmp_path / "no-such-program"
    assert lines[0].endswith(f"exec {missing} --now 'a b': Low violated  FAILED: no such "
                             f"program: {missing}"), lines  # fmt: skip
    assert lines[1].endswith("exited with code 3"), lines
    assert "tcp 127.0.0.1" in lines[2] and "FAILED: connection refused" in lines[2], lines
    assert "post http://127.0.0.1" in lines[3] and "FAILED: connection refused" in lines[3]
    assert lines[4].endswith("log error: x went high") and "FAILED" not in lines[4]
    assert text.out.rstrip().endswith("FAILED: 1 violation, 0 intrusions, 4 actions failed")
    jsonl = rmv("replay", str(spec), str(recording), "--run-actions", "--format", "jsonl")
    errors = [json.loads(line).get("error") for line in jsonl.out.splitlines()
              if json.loads(line)["kind"] == "action"]  # fmt: skip
    assert errors[0] == f"no such program: {missing}" and errors[4] is None
    assert all("Errno" not in (e or "") for e in errors), errors
