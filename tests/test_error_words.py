"""Errors that scale with the mistake, in the user's words (issue 36): a run of
characters no token starts with is one error, a name in another script is one
error that says why, a long line is cut around its mark, a file's diagnostics are
drawn up to a cap with a count of the rest, a declaration with too many errors is
left unread, `==` in a condition gets InfluxQL's `=`; an empty spec is said to check
nothing; and the system's refusals come in words, not as Python's."""

from __future__ import annotations

import random
import time
from pathlib import Path

import pytest
from conftest import EXAMPLES

HEAD = 'system s\ntopic t: std_msgs/msg/Float64 = "/t"\nvar x = t.data\n'


def _check(rmv, tmp_path: Path, text: str | bytes, name: str = "spec.rmv"):
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return rmv("check", str(path))


def test_a_run_of_stray_characters_is_one_error(rmv, tmp_path):
    result = _check(rmv, tmp_path, b"\0" * 500)
    assert result.out.count("error[RMV101]") == 1, result.out
    assert "unexpected characters `␀␀␀…␀␀␀` (500 characters)" in result.out
    assert len(result.out) < 2000
    result = _check(rmv, tmp_path, HEAD + "event E when x > 5\nproperty P: not E\n$$$ @@\n")
    assert "unexpected characters `$$$`" in result.out and "`@@`" in result.out
    assert result.out.count("error[RMV101]") == 2


def test_a_name_in_another_script_is_one_clear_error(rmv, tmp_path):
    result = _check(rmv, tmp_path, HEAD + "var Скорость = t.data\n")
    assert result.out.count("error[") == 1, result.out
    assert "`Скорость` is not a name: names are ASCII letters, digits and `_`" in result.out


def test_double_equals_in_a_condition_says_influxql_uses_one(rmv, tmp_path):
    result = _check(rmv, tmp_path, HEAD + "event E when x == 5\nproperty P: not E\n")
    assert "conditions are InfluxQL, which compares with one `=`: write `x = 5`" in result.out


def test_junk_gives_a_page_quickly_not_megabytes(rmv, tmp_path):
    """100 KB of random printable characters (and a few letters of other scripts):
    a bounded number of errors, a bounded output, in about the time of a spec."""
    rng = random.Random(36)
    alphabet = [chr(c) for c in range(32, 127)] + ["é", "Ж", "中", "\n"] * 3
    began = time.monotonic()
    result = _check(rmv, tmp_path, "".join(rng.choice(alphabet) for _ in range(100_000)))
    took = time.monotonic() - began
    assert result.code == 1
    assert len(result.out) < 200_000, len(result.out)
    assert "errors in this declaration: the rest of it, to line" in result.out or (
        "more diagnostics not shown" in result.out
    )
    assert took < 60, took  # it never ends no more (it took 15.8 s before the caps here)


def test_a_long_line_is_cut_around_its_mark(rmv, tmp_path):
    long_sum = " + ".join(["x"] * 3000)
    result = _check(rmv, tmp_path, HEAD + f"event E when {long_sum} > 5 $ x\nproperty P: not E\n")
    line = next(row for row in result.out.splitlines() if row.startswith("4 |"))
    assert line.startswith("4 | …") and line.endswith("> 5 $ x") and len(line) < 200, line


def test_diagnostics_are_drawn_up_to_a_cap_per_file(rmv, tmp_path):
    result = _check(rmv, tmp_path, "system s\n" + "".join(f"var x{i} = $\n" for i in range(300)))
    assert result.out.count("error[") == 100
    assert "200 more diagnostics not shown (`--format json` lists every one)" in result.out
    assert result.out.rstrip().endswith("300 errors, 0 warnings")


def test_an_empty_spec_checks_nothing_and_does_not_replay_as_passed(rmv, tmp_path):
    result = _check(rmv, tmp_path, "", "empty.rmv")
    assert result.code == 0
    assert "warning[RMV226]: the spec checks nothing" in result.out
    replayed = rmv("replay", str(tmp_path / "empty.rmv"),
                   str(EXAMPLES / "carla" / "recordings" / "braking.bag"))  # fmt: skip
    assert replayed.code == 2 and "the spec checks nothing" in replayed.err
    built = rmv("build", "--target", "ros2", str(tmp_path / "empty.rmv"), "-o",
                str(tmp_path / "pkg"))  # fmt: skip
    assert built.code == 0 and "package `empty`" in built.out and "RMV226" in built.err


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["check", "{abs}", "--witnesses", "{file}"],
         "--witnesses {file}: a file is in the way: a folder is needed there"),
        (["build", "--target", "ros2", "{abs}", "-o", "{file}/pkg"],
         "{file}/pkg: a part of the path is a file, not a folder"),
        (["import", "{empty_yaml}"],
         "expected a YAML mapping at the top (`topics:` ...), found nothing (the file is empty)"),
        (["replay", "{abs}", "{fake_bag}"],
         "cannot read the recording: its metadata.yaml is damaged, or not a rosbag2 recording's"),
    ],
)  # fmt: skip
def test_the_system_s_refusals_in_words(rmv, tmp_path, args, says):
    (tmp_path / "file").write_text("x")
    (tmp_path / "empty.yaml").write_text("")
    (tmp_path / "fake").mkdir()
    (tmp_path / "fake" / "metadata.yaml").write_text("x\n")
    names = {
        "abs": str(EXAMPLES / "carla" / "abs.rmv"),
        "file": str(tmp_path / "file"),
        "empty_yaml": str(tmp_path / "empty.yaml"),
        "fake_bag": str(tmp_path / "fake"),
    }
    result = rmv(*(a.format(**names) for a in args))
    assert result.code == 2 and says.format(**names) in result.err, result.err
    for internal in ("File exists", "Not a directory", "NoneType", "string indices", "Errno"):
        assert internal not in result.err
