"""What a user installs is what the tests ran: the wheel holds every file of
rmvdsl/ that git holds, data is read as package data (never by a path beside the
source that only a checkout has), and a generated ROS package declares every
package it imports."""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import pytest
from conftest import EXAMPLES, FIXTURES, INSTALLED, INSTALLED_WHEEL, ROOT

import rmvdsl
from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.targets import kapacitor, ros2

PACKAGE = Path(rmvdsl.__file__).parent


def _tracked() -> set[str]:
    """The files under rmvdsl/ that git tracks or would track (not ignored)."""
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "rmvdsl"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout.split()  # fmt: skip
    return {p for p in listed if (ROOT / p).exists()}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel the suite's venv was installed from, or one built now from the
    checkout by the same script."""
    if INSTALLED_WHEEL is not None:
        return INSTALLED_WHEEL
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(["bash", str(ROOT / "tests" / "install-wheel.sh"), "--wheel-only", str(out)],
                   check=True, capture_output=True, timeout=600)  # fmt: skip
    return next(out.glob("rmvdsl-*.whl"))


def _files(folder: Path) -> set[str]:
    """The files of the rmvdsl package installed in `folder` (bytecode aside)."""
    return {
        p.relative_to(folder).as_posix() for p in (folder / "rmvdsl").rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    }  # fmt: skip


def test_the_wheel_holds_every_file_git_holds(wheel: Path):
    assert (ROOT / ".git").exists(), "the tests run in a git checkout: git lists its files"
    with zipfile.ZipFile(wheel) as archive:
        packed = {n for n in archive.namelist() if n.startswith("rmvdsl/")}
    assert packed == _tracked()


def test_what_is_installed_is_the_wheel(wheel: Path, tmp_path: Path):
    """pip installs every file of the wheel: into the suite's venv (run installed),
    or here into a folder of its own (run from an editable install)."""
    if INSTALLED:
        folder = PACKAGE.parent
    else:
        subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                        "--target", str(tmp_path), str(wheel)],
                       check=True, capture_output=True, timeout=300)  # fmt: skip
        folder = tmp_path
    with zipfile.ZipFile(wheel) as archive:
        assert _files(folder) == {n for n in archive.namelist() if n.startswith("rmvdsl/")}


def test_a_child_python_imports_the_installed_package(tmp_path: Path):
    """Processes the tests start see the same rmvdsl as the tests."""
    where = subprocess.run(
        [sys.executable, "-c", "import rmvdsl; print(rmvdsl.__file__)"],
        cwd=tmp_path, capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    assert Path(where).resolve() == Path(rmvdsl.__file__).resolve()
    if INSTALLED:
        assert Path(where).resolve().parent != ROOT / "rmvdsl"


def _oldest_pins() -> list[str]:
    """`name==version` for each dependency the installed package declares for this
    Python, at the lowest version it accepts."""
    import importlib.metadata

    from packaging.requirements import Requirement

    pins = []
    for text in importlib.metadata.requires("rmvdsl") or []:
        requirement = Requirement(text)
        if requirement.marker is not None and not requirement.marker.evaluate({"extra": ""}):
            continue
        lowest = [s.version for s in requirement.specifier if s.operator == ">="]
        assert len(lowest) == 1, f"{text}: a dependency names the lowest version it takes"
        pins.append(f"{requirement.name}=={lowest[0]}")
    return pins


SPEC_WITH_ERRORS = """system typed "an unsaved buffer"
ros humble
topic twist: geometry_msgs/msg/Twist = "/cmd"
var Speed =   twist.linear.x
event Fast when Speed > 25
property NeverFast: not Fsat
"""


def _editor_session(cwd: Path, env: dict[str, str]) -> list[Any]:
    """`rmv lsp` as an editor meets it: the diagnostics of a buffer with an
    unknown name, a completion in its formula, a hover, a formatting."""
    from lsp_wire import Wire

    wire = Wire(cwd=cwd, env=env)
    try:
        return _edits(wire, cwd)
    except (EOFError, TimeoutError, BrokenPipeError) as error:
        wire.process.kill()
        wire.stderr_reader.join(10)
        raise AssertionError(f"{error}; the server said: {wire.stderr[-3000:]!r}") from None
    finally:
        if wire.process.poll() is None:
            assert wire.close() == 0, wire.stderr


def _edits(wire: Any, cwd: Path) -> list[Any]:
    """What the server answered, each answer asked to hold something."""
    wire.initialize(cwd)
    uri = wire.open(cwd / "typed.rmv", SPEC_WITH_ERRORS)
    published = wire.diagnostics_until(uri, lambda p: bool(p["diagnostics"]))
    line = SPEC_WITH_ERRORS.splitlines().index("property NeverFast: not Fsat")
    at = {"textDocument": {"uri": uri}, "position": {"line": line, "character": 24}}
    completion = wire.call("textDocument/completion", at)["result"]
    items = completion["items"] if isinstance(completion, dict) else completion
    hover = wire.call("textDocument/hover", {**at, "position": {"line": 3, "character": 5}})
    formatting = wire.call(
        "textDocument/formatting",
        {"textDocument": {"uri": uri}, "options": {"tabSize": 4, "insertSpaces": True}},
    )
    assert items and hover["result"] and formatting["result"], (items, hover, formatting)
    return [published["diagnostics"], sorted(i["label"] for i in items),
            hover["result"], formatting["result"]]  # fmt: skip


def test_the_oldest_dependencies_the_package_accepts_work_alike(tmp_path: Path):
    """The package accepts each dependency from the version its metadata names:
    with all of those at once (installed beside the suite's, first on the path),
    `rmv check` of every example (lark, networkx, z3), `rmv build` of every target
    (jinja2), `rmv eval` of a trace (msgspec), `rmv replay` of the example's three
    recordings (rosbags) and an editor's session with `rmv lsp` (pygls) give what
    the suite's versions give, in new processes. (`rosbags>=0.10` was declared
    while 0.10.x to 0.11.0 stopped every replay with an ImportError.)"""
    from rmvdsl.targets import REGISTRY

    old = tmp_path / "old"
    pins = _oldest_pins()
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--target", str(old),
                    *pins], check=True, capture_output=True, timeout=600)  # fmt: skip
    trace = tmp_path / "trace.jsonl"
    trace.write_text('{"state": "A", "t": 0}\n{"t": 1, "x": [1], "state": "B"}\n'
                     '{"t": 2.5, "state": "A"}\n{"end": true, "t": 4}\n')  # fmt: skip
    specs = sorted(str(p) for p in EXAMPLES.rglob("*.rmv"))
    carla = str(EXAMPLES / "carla" / "abs.rmv")
    recordings = EXAMPLES / "carla" / "recordings"

    def outcome(path: Path | None) -> list[Any]:
        home = tmp_path / "home"  # one place for both: outputs name their paths
        shutil.rmtree(home, ignore_errors=True)
        home.mkdir()
        env = {**os.environ, "RMV_CACHE_DIR": str(home / "cache")}
        env.pop("PYTHONPATH", None)
        if path is not None:
            env["PYTHONPATH"] = str(path)

        def rmv(*args: str) -> tuple[int, str, str]:
            done = subprocess.run([sys.executable, "-m", "rmvdsl.cli", *args], cwd=home,
                                  capture_output=True, text=True, env=env, timeout=300)  # fmt: skip
            return done.returncode, done.stdout, done.stderr

        found: list[Any] = [rmv("check", "--jobs", "1", *specs)]
        for target in REGISTRY:
            out = tmp_path / "built" / target  # one place: a package names its own path
            shutil.rmtree(out, ignore_errors=True)
            out.parent.mkdir(parents=True, exist_ok=True)
            found.append(rmv("build", "--target", target, carla, "-o", str(out)))
            built = sorted(p for p in out.rglob("*") if p.is_file())
            found.append({str(p.relative_to(out)): p.read_bytes() for p in built})
        found.append(rmv("eval", "--formula", "always[<=4] (A or B)", "--trace", str(trace)))
        for recording in ("braking.bag", "braking_db3", "braking_mcap"):
            found.append(rmv("replay", carla, str(recordings / recording), "--format", "jsonl"))
        found.append(_editor_session(home, env))
        return found

    versions = subprocess.run(
        [sys.executable, "-c", "import importlib.metadata as m, sys; "
         "print([m.version(p.split('==')[0]) for p in sys.argv[1:]])", *pins],
        env={**os.environ, "PYTHONPATH": str(old)}, capture_output=True, text=True, check=True,
    )  # fmt: skip
    from packaging.version import Version

    installed = [Version(v) for v in ast.literal_eval(versions.stdout)]
    assert installed == [Version(p.split("==")[1]) for p in pins], versions.stdout
    oldest, newest = outcome(old), outcome(None)
    for given, expected in zip(oldest, newest, strict=True):
        assert given == expected


# Modules that may name __file__: to find the package itself, not data beside it.
FINDS_ITSELF = {"util/processes.py"}


def test_data_is_read_as_package_data():
    """No module finds a data file by a path from __file__ (it would hold in a
    checkout only); templates and runtime sources come through importlib.resources."""
    naming = {
        str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
        if re.search(r"\b__file__\b", p.read_text(encoding="utf-8"))
    }  # fmt: skip
    assert naming <= FINDS_ITSELF, naming - FINDS_ITSELF


def _imported(source: str) -> set[str]:
    """The top-level packages a Python file imports absolutely (importlib's dynamic
    imports of message packages aside)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.split(".")[0])
    return found - set(sys.stdlib_module_names) - {"__future__"}


def _declared(package_xml: str) -> set[str]:
    return set(re.findall(r"<(?:exec_|build_)?depend>([^<]+)</", package_xml))


SPECS = (
    EXAMPLES / "carla" / "abs.rmv", EXAMPLES / "gazebo" / "prius_platoon.rmv",
    FIXTURES / "regressions" / "collector_without_std_msgs.rmv",
)  # fmt: skip


def _packages() -> dict[str, dict[str, str]]:
    """Each ROS package the targets write for the examples: folder -> files."""
    from rmvdsl.targets.ros1 import generate as ros1

    out: dict[str, dict[str, str]] = {}
    for spec_path in SPECS:
        spec = lower(check(str(spec_path)))
        out[f"ros2 {spec_path.name}"] = ros2.files(spec)
        out[f"ros1 {spec_path.name}"] = ros1.files(spec)
        for ros in ("ros2", "ros1"):
            texts, _ = kapacitor.files(spec, Path("build"), ros)
            collector = {p.removeprefix("collector/"): t for p, t in texts.items()
                         if p.startswith("collector/")}  # fmt: skip
            out[f"kapacitor-{ros} {spec_path.name}"] = collector
    return out


# What a ROS 1 package's nodes import from PyPI, which no ROS package provides
# (the generated README and docs/ros1.md say how to install it).
PYPI = {"ros1": {"rosbags"}, "ros2": set()}


@pytest.mark.parametrize("name", sorted(_packages()))
def test_a_generated_package_declares_what_it_imports(name: str):
    files = _packages()[name]
    own = re.search(r"<name>([^<]+)</name>", files["package.xml"]).group(1)  # type: ignore[union-attr]
    declared = _declared(files["package.xml"])
    imported: set[str] = set()
    for path, text in files.items():
        # setup.py: the build's own (ament_python, catkin); scripts/: ROS 1's nodes
        if (path.endswith(".py") or path.startswith("scripts/")) and path != "setup.py":
            imported |= _imported(text)
    imported.discard(own)
    ros = "ros1" if "package.xml" in files and "catkin" in files["package.xml"] else "ros2"
    imported -= PYPI[ros]
    assert imported - declared == set(), f"imported but not in package.xml: {imported - declared}"
    # ROS 2: message packages are imported by name when the node starts
    # (rmv_host.ros2_definitions.class_of); ROS 1 decodes them from the connection header.
    spec = lower(check(str(_spec_of(name))))
    messages = set(ros2.message_packages(spec)) if ros == "ros2" else set()
    unused = declared - imported - messages - {"catkin"}
    assert unused == set(), f"declared but never imported: {unused}"


def _spec_of(name: str) -> Path:
    file = name.split()[1]
    return next(p for p in SPECS if p.name == file)


def test_the_check_finds_an_undeclared_import():
    text = "import launch_ros\nfrom rclpy.node import Node\nimport json\n"
    assert _imported(text) == {"launch_ros", "rclpy"}
    assert _declared("<exec_depend>rclpy</exec_depend>") == {"rclpy"}
