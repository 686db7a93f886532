"""Every line rmv writes for a person is safe for a terminal: names, paths and words
from specs, traces, recordings and the command line show their control characters
as pictures (rmvdsl.runtime.wording.visible), never as escapes a terminal obeys.
What a command writes as data (JSON, generated code, a formatted spec) is exact."""

from __future__ import annotations

import ast
import json
import re

from conftest import EXAMPLES, ROOT, damaged_bag

from rmvdsl.runtime.wording import visible

# A title set (OSC ... BEL), a colour (CSI), a NUL and a C1 CSI: what a terminal obeys.
HOSTILE = "\x1b]0;owned\x07\x1b[31m\x9b2J"
# Any control character but a line break or a tab, and C1's.
_OBEYED = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


def _safe(text: str) -> bool:
    return _OBEYED.search(text) is None


def test_visible_draws_every_control_character_and_keeps_the_rest():
    drawn = visible("a\tb\nc" + HOSTILE + "\x00\x7f é ✓")
    assert _safe(drawn)
    assert drawn == "a\tb\nc␛]0;owned␇␛[31m\ufffd2J␀␡ é ✓"


def test_no_command_prints_but_through_say():
    """`say` is the one way a command writes a line for a person (a print of its own
    would skip `visible`)."""
    files = [ROOT / "rmvdsl" / "cli.py", *sorted((ROOT / "rmvdsl" / "commands").glob("*.py"))]
    found = []
    for path in files:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for function in ast.walk(tree):
            if isinstance(function, ast.FunctionDef) and function.name == "say":
                function.body = []  # its own print is the one allowed
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not found, found


def test_a_trace_s_names_and_fields_are_shown_drawn(rmv, tmp_path):
    trace = tmp_path / "t.jsonl"
    trace.write_text(json.dumps({"t": 0, "state": "p" + HOSTILE}) + "\n", encoding="utf-8")
    run = rmv("eval", "--formula", "p", "--trace", str(trace))
    assert run.code == 2 and "is not a proposition name" in run.err, run.err
    assert _safe(run.err) and "␛]0;owned␇" in run.err
    trace.write_text(json.dumps({"t": 0, "state": "p", HOSTILE: 1}) + "\n", encoding="utf-8")
    run = rmv("eval", "--formula", "p", "--trace", str(trace))
    assert run.code == 0 and "fields other than t" in run.err, run.err
    assert _safe(run.err) and "␛]0;owned␇" in run.err


def test_a_path_and_an_argument_are_shown_drawn(rmv, tmp_path):
    missing = tmp_path / f"spec{HOSTILE}.rmv"
    run = rmv("check", str(missing))
    assert run.code == 2 and _safe(run.err) and "spec␛]0;owned␇" in run.err, run.err
    run = rmv("check", f"--colour{HOSTILE}", str(missing))  # argparse's own error
    assert run.code == 2 and _safe(run.err) and "--colour␛" in run.err, run.err
    wrong = tmp_path / f"wrong{HOSTILE}.rmv"
    wrong.write_text("system s\nvar X = nowhere.x\n", encoding="utf-8")
    run = rmv("check", str(wrong))  # the diagnostic's `-->` line and the summary
    assert run.code == 1 and _safe(run.out), run.out
    arrows = [line for line in run.out.splitlines() if "-->" in line]
    assert arrows and all("wrong␛]0;owned␇" in line for line in arrows), run.out
    assert "wrong␛]0;owned␇" in run.out.splitlines()[-1], run.out
    untidy = tmp_path / f"untidy{HOSTILE}.rmv"
    untidy.write_text('system s\ntopic  t: std_msgs/Bool = "/t"\n', encoding="utf-8")
    run = rmv("fmt", "--check", str(untidy))
    assert run.code == 1 and _safe(run.out) and "would reformat" in run.out, run.out


def test_a_recorded_caller_id_is_shown_drawn_in_text_and_exact_in_json(rmv, tmp_path):
    """A ROS 1 bag names each connection's publisher: anyone's string. The replay's
    text line of the intrusion draws it; its JSON keeps it exactly (escaped)."""
    bag = tmp_path / "rogue.bag"
    rogue = "/rogue" + HOSTILE
    damaged_bag(bag, rogue)
    spec = str(EXAMPLES / "carla" / "abs.rmv")
    text = rmv("replay", spec, str(bag))
    assert text.code == 1, text.err  # the rogue publisher is an intrusion
    intrusions = [line for line in text.out.splitlines() if line.startswith("intrusion")]
    assert intrusions and all("/rogue␛]0;owned␇" in line for line in intrusions), text.out
    assert _safe(text.out) and _safe(text.err)
    lines = rmv("replay", spec, str(bag), "--format", "jsonl")
    nodes = {json.loads(line).get("node") for line in lines.out.splitlines()}
    assert rogue in nodes


def test_a_fleet_s_text_lines_are_drawn(rmv, tmp_path):
    """A recording's line in a fleet's text output holds its path and the words of
    its failure: both anyone's."""
    read, bad = tmp_path / "read.bag", tmp_path / f"bad{HOSTILE}.bag"
    damaged_bag(read, "/rogue" + HOSTILE)
    bad.write_bytes(b"#ROSBAG V2.0\n" + HOSTILE.encode() * 100)
    run = rmv("replay", str(EXAMPLES / "carla" / "abs.rmv"), str(read), str(bad), "--jobs", "1")
    assert run.code != 0 and "bad␛]0;owned␇" in run.out, run.out
    assert _safe(run.out) and _safe(run.err), (run.out, run.err)
