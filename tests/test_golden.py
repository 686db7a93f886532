"""The deliberate mistakes of examples/errors/: their diagnostics, exactly.

Regenerate the .expected files with `UPDATE_GOLDEN=1 pytest tests/test_golden.py`
after a deliberate change. In that mode these tests cannot fail, so a regenerated
file is reviewed as code: `git diff examples/errors` is read line by line, and the
commit that changes a golden file says why each changed diagnostic is now right.
`test_hand_written_expectations` below never regenerates: it pins, by hand, where
the most important findings must be.
"""

from __future__ import annotations

import os
import re

import pytest
from conftest import EXAMPLES, ROOT

ERROR_SPECS = sorted(
    p
    for p in (EXAMPLES / "errors").rglob("*.rmv")
    if p.name not in {"common.rmv", "cycle_b.rmv", "latin1.rmv"}
)


@pytest.mark.parametrize("spec", ERROR_SPECS, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_error_example_matches_golden(spec, rmv):
    """A first line `// rmv check OPTIONS` adds OPTIONS (`--target kapacitor`)."""
    relative = str(spec.relative_to(ROOT))
    first = spec.read_text(encoding="utf-8").splitlines()[0]
    options = first.split()[3:] if first.startswith("// rmv check ") else []
    result = rmv("check", "--no-color", *options, relative)
    assert result.code == (1 if "error[" in result.out or not options else 0), result.out
    golden = spec.with_suffix(".expected")
    if os.environ.get("UPDATE_GOLDEN"):
        golden.write_text(result.out, encoding="utf-8")
    assert result.out == golden.read_text(encoding="utf-8")


def test_every_code_has_a_golden_case():
    from rmvdsl.lang.codes import CODES

    seen = set()
    for golden in (EXAMPLES / "errors").rglob("*.expected"):
        seen |= set(re.findall(r"\[(RMV\d{3})\]", golden.read_text(encoding="utf-8")))
    assert set(CODES) - seen == set()


@pytest.mark.parametrize(
    "spec", ["carla/abs.rmv", "gazebo/prius_platoon.rmv", "gazebo/network.rmv"]
)
def test_good_examples_check_clean(spec, rmv):
    result = rmv("check", "--strict", f"examples/{spec}")
    assert result.code == 0, result.out
    assert result.out == f"examples/{spec}: 0 errors, 0 warnings\n"


# (code, line, column) of every diagnostic, written by hand from reading the specs.
HAND_WRITTEN = {
    "errors/analysis.rmv": [
        ("RMV501", 14, 24),  # Hard: its only way out, on Impossible, never holds
        ("RMV500", 14, 30),  # Limbo: nothing leads there
        ("RMV500", 14, 37),  # Parked: entered only on FromLimbo, never emitted
        ("RMV505", 17, 5),  # Idle: SoftBrake and HardBrake overlap (BrakePedal > 0.8)
        ("RMV503", 18, 31),  # Halted is emitted, never used
        ("RMV502", 19, 21),  # Impossible: Velocity > 5 and Velocity < 1
        ("RMV502", 21, 23),  # FromLimbo: emitted only from Limbo
        ("RMV504", 24, 12),  # Gearbox: nothing looks at it
        ("RMV506", 25, 12),  # Neutral: no transition when Velocity <= 1
        ("RMV506", 25, 21),  # Driving: no transition when Velocity >= 0.1
    ],
    "errors/temporal.rmv": [("RMV212", 14, 32), ("RMV212", 15, 34)],  # the keywords alone
    "errors/keywords.rmv": [
        ("RMV203", 4, 7), ("RMV221", 4, 7), ("RMV203", 5, 7), ("RMV221", 5, 7),
    ],
    "errors/units.rmv": [
        ("RMV105", 5, 19), ("RMV219", 7, 11), ("RMV213", 17, 41), ("RMV219", 18, 43),
        ("RMV203", 22, 7), ("RMV219", 22, 42), ("RMV203", 23, 7), ("RMV223", 23, 42),
        ("RMV203", 26, 7), ("RMV106", 26, 28), ("RMV203", 27, 7), ("RMV106", 27, 28),
    ],
}  # fmt: skip


@pytest.mark.parametrize("spec", sorted(HAND_WRITTEN))
def test_hand_written_expectations(spec, rmv):
    import json

    result = rmv("check", "--format", "json", str(EXAMPLES / spec))
    found = [(d["code"], d["line"], d["column"]) for d in json.loads(result.out)]
    assert found == HAND_WRITTEN[spec]
