"""The deliberate mistakes of examples/errors/: their diagnostics, exactly.

Regenerate the .expected files with `UPDATE_GOLDEN=1 pytest tests/test_golden.py`
after a deliberate change, and read the diff.
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
    relative = str(spec.relative_to(ROOT))
    result = rmv("check", "--no-color", relative)
    assert result.code == 1, result.out
    golden = spec.with_suffix(".expected")
    if os.environ.get("UPDATE_GOLDEN"):
        golden.write_text(result.out, encoding="utf-8")
    assert result.out == golden.read_text(encoding="utf-8")


def test_every_code_has_a_golden_case():
    from rmvdsl.codes import CODES

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
