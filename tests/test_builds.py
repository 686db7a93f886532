"""Every target of the registry, built by `rmv build` from every example, exactly:
a move or a redesign of the targets keeps their output byte for byte.

Regenerate with `UPDATE_GOLDEN=1 pytest tests/test_builds.py` after a deliberate
change and read `git diff tests/golden/builds` as code. A package's copies of the
runtime (rmv_runtime/) and of the host (rmv_host/) are left out: they are
rmvdsl/runtime/ and rmvdsl/host/, and tests/test_install.py runs them as built; a
package's spec.json is compared with the ir target's output.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from conftest import ROOT

from rmvdsl.targets import REGISTRY

GOLDEN = ROOT / "tests" / "golden" / "builds"
SPECS = ["carla/abs.rmv", "gazebo/prius_platoon.rmv", "gazebo/network.rmv"]
# The kapacitor target writes its handlers' absolute path into the TICKscripts.
OUT = "OUT"


def _written(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): p.read_text(encoding="utf-8").replace(str(folder), OUT)
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != "spec.json"
        and not {"rmv_runtime", "rmv_host", "__pycache__"} & set(p.parts)
    }  # fmt: skip


@pytest.mark.parametrize("target", list(REGISTRY))
@pytest.mark.parametrize("spec", SPECS)
def test_every_target_builds_every_example_as_before(rmv, tmp_path, spec, target):
    out = tmp_path / "out"
    # A relative path: the resolved spec names its origins by the path it was given.
    run = rmv("build", "--target", target, f"examples/{spec}", "-o", str(out))
    if run.code != 0:  # a spec the target cannot build: what it says, exactly
        written = {"refused": f"exit {run.code}\n{run.err}"}
    elif out.is_dir():
        written = _written(out)
        # The resolved spec a package carries is the ir target's output.
        ir_out = (GOLDEN / Path(spec).stem / "ir" / "out").read_text(encoding="utf-8")
        carried = [p.read_text(encoding="utf-8") for p in out.rglob("spec.json")]
        # The C monitors carry node tables, not the spec.
        assert (carried or target == "c") and all(text == ir_out for text in carried)
    else:
        written = {"out": out.read_text(encoding="utf-8")}
    folder = GOLDEN / Path(spec).stem / target
    if os.environ.get("UPDATE_GOLDEN"):
        shutil.rmtree(folder, ignore_errors=True)
        for relative, text in written.items():
            (folder / relative).parent.mkdir(parents=True, exist_ok=True)
            (folder / relative).write_text(text, encoding="utf-8")
    assert _written(folder) == written
