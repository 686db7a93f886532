"""Every function of the registry, run through the checker, the resolved spec and
the runtime on the worked examples of docs/runtime.md ("Value events, function by
function"). The expected points there are derived by hand from InfluxDB 1.x's rules;
this test makes sure the runtime computes exactly them, so the page cannot drift."""

from __future__ import annotations

import math
import re
from fractions import Fraction

import pytest
from conftest import ROOT

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.lang.builtins import FUNCTIONS
from rmvdsl.runtime.engine import Runtime

PAGE = (ROOT / "docs" / "runtime.md").read_text(encoding="utf-8")
HEADER = 'system Doc\ntopic t: std_msgs/msg/Float64 = "/t"\nvar x = t.data\n'
NS = 10**9


def _input() -> list[tuple[Fraction, float]]:
    block = re.search(r"```input\n(.*?)```", PAGE, re.S)
    assert block, "docs/runtime.md lost its input block"
    rows = dict(line.split(":", 1) for line in block.group(1).strip().splitlines())
    times = [Fraction(t) for t in rows["t (s)"].split()]
    values = [float(v) for v in rows["x"].split()]
    assert len(times) == len(values)
    return list(zip(times, values, strict=True))


INPUT = _input()
END = Fraction(5)  # the input ends at 5 s
EXAMPLES = re.findall(r"```event\n(.*?)\n=> ?(.*?)\n```", PAGE, re.S)


def _value(text: str) -> object:
    text = text.strip()
    if text in ("true", "false"):
        return text == "true"
    if re.fullmatch(r"-?\d+", text):
        return int(text)
    return float(text)


def _points(text: str) -> list[tuple[Fraction, object]]:
    if text.strip() == "nothing":
        return []
    pairs = [p.split(":") for p in text.split(",")]
    return [(Fraction(t.strip()), _value(v)) for t, v in pairs]


def _same(actual: object, expected: object) -> bool:
    if isinstance(expected, float):
        return isinstance(actual, float) and (
            math.isclose(actual, expected, rel_tol=1e-12, abs_tol=1e-12)
            or (math.isnan(actual) and math.isnan(expected))
        )
    return type(actual) is type(expected) and actual == expected


def _run(declarations: str, tmp_path) -> list[tuple[Fraction, object]]:
    path = tmp_path / "doc.rmv"
    path.write_text(HEADER + declarations + "\n", encoding="utf-8")
    result = check(str(path))
    assert not result.errors, [str(d) for d in result.errors]
    runtime = Runtime(lower(result))
    for time, value in INPUT:
        runtime.message(int(time * NS), "/t", {"data": value})
    runtime.end(int(END * NS))
    return [(r["time"], r["value"]) for r in runtime.records() if r.get("name") == "E"]


@pytest.mark.parametrize(("declarations", "expected"), EXAMPLES, ids=[e[0] for e in EXAMPLES])
def test_worked_example(declarations, expected, tmp_path):
    actual = _run(declarations, tmp_path)
    some = re.fullmatch(r"any (\d+) per window of (.*)", expected.strip())
    if some:  # `sample`: random, so only which points may appear is known
        allowed = _points(some.group(2))
        assert actual and all(any(_same(a, e) for e in allowed) for a in actual), actual
        by_window = {int(t) for t, _ in actual}
        assert all(sum(int(t) == w for t, _ in actual) <= int(some.group(1)) for w in by_window)
        return
    wanted = _points(expected)
    assert len(actual) == len(wanted), actual
    for (time, value), (want_time, want_value) in zip(actual, wanted, strict=True):
        assert time == want_time and _same(value, want_value), (actual, wanted)


def test_every_function_has_a_worked_example():
    used = {name for block, _ in EXAMPLES for name in re.findall(r"(\w+)\(", block)}
    assert set(FUNCTIONS) - used == set()
