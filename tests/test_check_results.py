"""A re-check of unchanged inputs prints what the last check printed without
parsing (rmvdsl.commands.stored); any change to an input the check read makes it
check again. Run as new processes, as users run `rmv check`."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import EXAMPLES, RMV

HEAVY = ("rmvdsl.check", "rmvdsl.grammar", "lark", "z3", "networkx", "jinja2", "rosbags",
         "matplotlib")  # fmt: skip
# Runs `rmv` in this process and prints which heavy modules it imported.
PROBE = (
    "import sys\nfrom rmvdsl.cli import main\n"
    "try:\n    code = main(sys.argv[1:])\nexcept SystemExit as exc:\n    code = exc.code\n"
    f"print('loaded', sorted(m for m in sys.modules "
    f"if any(m == h or m.startswith(h + '.') for h in {HEAVY!r})), code)"
)


def _run(folder: Path, cache: Path, *args: str) -> subprocess.CompletedProcess[str]:
    environment = {**os.environ, "RMV_CACHE_DIR": str(cache), "NO_COLOR": "1"}
    return subprocess.run([*RMV, *args], cwd=folder, env=environment, capture_output=True,
                          text=True, timeout=300)  # fmt: skip


def _probe(folder: Path, cache: Path, *args: str) -> str:
    environment = {**os.environ, "RMV_CACHE_DIR": str(cache), "NO_COLOR": "1"}
    probe = subprocess.run([sys.executable, "-c", PROBE, *args], cwd=folder, env=environment,
                           capture_output=True, text=True, timeout=300)  # fmt: skip
    return probe.stdout.splitlines()[-1]


@pytest.fixture
def carla(tmp_path: Path) -> Path:
    shutil.copytree(EXAMPLES / "carla", tmp_path / "carla", ignore=shutil.ignore_patterns("rec*"))
    return tmp_path / "carla"


def test_version_and_help_load_no_checker(tmp_path: Path):
    assert _probe(tmp_path, tmp_path / "cache", "--version").startswith("loaded []")


def test_an_unchanged_recheck_is_answered_without_parsing(carla: Path, tmp_path: Path):
    cache = tmp_path / "cache"
    first = _run(carla, cache, "check", "abs.rmv")
    assert (first.returncode, first.stdout) == (0, "abs.rmv: 0 errors, 0 warnings\n")
    assert _probe(carla, cache, "check", "abs.rmv") == "loaded [] 0"
    again = _run(carla, cache, "check", "abs.rmv")
    assert (again.returncode, again.stdout, again.stderr) == (0, first.stdout, first.stderr)


def _change_spec(carla: Path) -> None:
    spec = carla / "abs.rmv"
    spec.write_text(spec.read_text(encoding="utf-8").replace("< 4s", "< 3s", 1), encoding="utf-8")


def _change_message(carla: Path) -> None:
    path = next((carla / "msg").rglob("CarlaEgoVehicleControl.msg"))
    path.write_text(path.read_text(encoding="utf-8").replace("float32 brake", "float32 brak"),
                    encoding="utf-8")  # fmt: skip


def _add_message(carla: Path) -> None:
    folder = next((carla / "msg").rglob("CarlaEgoVehicleControl.msg")).parent
    (folder / "Extra.msg").write_text("int32 x\n", encoding="utf-8")


def _add_config(carla: Path) -> None:
    (carla / "rmv.toml").write_text('[check]\nsolver_efforts = "x"\n', encoding="utf-8")


@pytest.mark.parametrize("change", [_change_spec, _change_message, _add_message, _add_config],
                         ids=lambda f: f.__name__.strip("_"))  # fmt: skip
def test_a_changed_input_is_checked_again(change, carla: Path, tmp_path: Path):
    cache = tmp_path / "cache"
    _run(carla, cache, "check", "abs.rmv")
    change(carla)
    assert _probe(carla, cache, "check", "abs.rmv") != "loaded [] 0"
    stored = _run(carla, cache, "check", "abs.rmv")
    fresh = _run(carla, tmp_path / "empty", "check", "abs.rmv")
    assert (stored.returncode, stored.stdout, stored.stderr) == (
        fresh.returncode, fresh.stdout, fresh.stderr,
    )  # fmt: skip


def test_other_options_are_other_checks(carla: Path, tmp_path: Path):
    cache = tmp_path / "cache"
    _run(carla, cache, "check", "abs.rmv")
    as_json = _run(carla, cache, "check", "--format", "json", "abs.rmv")
    assert (as_json.returncode, as_json.stdout.strip()) == (0, "[]")
