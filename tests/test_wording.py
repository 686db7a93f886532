"""Counts read as a person writes them: "1 error", "2 errors". Every message that
puts a count before a noun goes through rmvdsl.runtime.wording.counted; a scan of
the package's f-strings finds a count written straight before a plural."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import rmvdsl
from rmvdsl.runtime.wording import counted

PACKAGE = Path(rmvdsl.__file__).parent
# Words after a placeholder that end in "s" but are verbs or particles, not plurals.
NOT_PLURALS = {
    "is", "has", "does", "holds", "needs", "as", "was", "reads", "takes", "says", "declares",
}  # fmt: skip


def _counts_before_plurals(source: str) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.JoinedStr):
            continue
        for value, after in zip(node.values, node.values[1:], strict=False):
            if not isinstance(value, ast.FormattedValue) or not isinstance(after, ast.Constant):
                continue
            word = re.match(r"^ ([a-z]+s)\b", str(after.value))
            call = value.value
            through = isinstance(call, ast.Call) and getattr(call.func, "id", "") == "counted"
            if word and word.group(1) not in NOT_PLURALS and not through:
                found.append(f"line {node.lineno}: {{{ast.unparse(call)}}}{after.value[:20]}")
    return found


def test_no_count_is_written_straight_before_a_plural():
    found = {
        str(path.relative_to(PACKAGE)): hits
        for path in sorted(PACKAGE.rglob("*.py"))
        if (hits := _counts_before_plurals(path.read_text(encoding="utf-8")))
    }
    assert found == {}


def test_the_scan_finds_a_count_before_a_plural():
    assert _counts_before_plurals('f"{len(errors)} errors"') == ["line 1: {len(errors)} errors"]
    assert _counts_before_plurals("f\"{counted(n, 'error')}\"") == []
    assert _counts_before_plurals('f"{name} has no field"') == []


@pytest.mark.parametrize(
    ("number", "noun", "plural", "expected"),
    [
        (0, "error", None, "0 errors"),
        (1, "error", None, "1 error"),
        (2, "error", None, "2 errors"),
        (1, "candidate trace", None, "1 candidate trace"),
        (3, "property", "properties", "3 properties"),
        (1, "property", "properties", "1 property"),
    ],
)
def test_counted(number: int, noun: str, plural: str | None, expected: str):
    assert counted(number, noun, plural) == expected


def test_grouped_counts():
    assert counted(1_000_000, "message", grouped=True) == "1,000,000 messages"
    assert counted(1, "message", grouped=True) == "1 message"


def test_the_command_line_says_one_error(rmv, tmp_path: Path):
    spec = tmp_path / "one.rmv"
    spec.write_text("system s\ntopic t: std_msgs/Int32 = \"/t\"\nvar V = t.nodata\n",
                    encoding="utf-8")  # fmt: skip
    result = rmv("build", "--target", "ros2", str(spec), "-o", str(tmp_path / "out"))
    assert result.code == 1
    assert result.err.rstrip().endswith(f"rmv build: {spec}: 1 error: nothing built")
    assert "1 errors" not in result.err + result.out
