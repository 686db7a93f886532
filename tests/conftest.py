from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
FIXTURES = Path(__file__).resolve().parent / "fixtures"

# The solver's answer cache: one per test session (shared with the processes the
# tests start), never the user's.
os.environ["RMV_CACHE_DIR"] = tempfile.mkdtemp(prefix="rmv-cache-")

# Run from the venv tests/install-wheel.sh made (it keeps the wheel in its wheel/
# folder), the suite tests the installed wheel and must not import the checkout's
# rmvdsl/ by accident.
INSTALLED_WHEEL = next(Path(sys.prefix, "wheel").glob("rmvdsl-*.whl"), None)
INSTALLED = INSTALLED_WHEEL is not None


def _rmv_command() -> list[str]:
    """How a user's shell starts rmv: the console script the install wrote beside
    this interpreter (`python -m rmvdsl.cli` would import rmvdsl/ from the current
    folder, the checkout, instead of what is installed)."""
    beside = Path(sys.executable).parent / "rmv"
    script = str(beside) if beside.exists() else shutil.which("rmv")
    if script:
        return [script]
    assert not INSTALLED, "the installed package has no `rmv` script beside its Python"
    return [sys.executable, "-m", "rmvdsl.cli"]


RMV = _rmv_command()


def pytest_configure(config: pytest.Config) -> None:
    import rmvdsl

    where = Path(rmvdsl.__file__).resolve()
    if INSTALLED and where.parent == ROOT / "rmvdsl":
        raise pytest.UsageError(
            f"the venv holds the installed wheel, but rmvdsl is imported from the checkout "
            f"({where}): run the venv's `pytest`, not `python -m pytest` (README)"
        )


# The files whose tests take longest, longest first (CI's durations, seconds of
# one worker): each worker takes a whole file (--dist loadfile), and a long file
# started last holds the suite after the other worker is done (CI once: 1,205 s).
# The rest keep the collection's order (--no-loadscope-reorder: xdist would
# otherwise put the files with the most tests first, and these have few).
LONGEST_FIRST = [
    "test_ros2.py",  # ~400: the workspace build, the soaks
    "test_c_dataflow.py",  # ~165
    "test_c_target.py",  # ~145
    "test_fuzz.py",  # ~100
    "test_lsp.py",  # ~100
    "test_ros1.py",  # ~90
    "test_soundness.py",  # ~85
]


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank = {name: place for place, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


@dataclass
class Run:
    code: int
    out: str
    err: str


@pytest.fixture
def rmv(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch):
    """Run the `rmv` command in-process, from the repository root."""
    from rmvdsl.cli import main

    monkeypatch.chdir(ROOT)
    monkeypatch.delenv("NO_COLOR", raising=False)

    def run(*args: str) -> Run:
        capsys.readouterr()
        try:
            code = main(list(args))
        except SystemExit as exc:  # argparse's --help, --version and usage errors
            code = int(exc.code or 0)
        captured = capsys.readouterr()
        return Run(code, captured.out, captured.err)

    return run


def rmv_process(
    args: Sequence[str],
    cwd: Path = ROOT,
    stdin: str | None = None,
    env: dict[str, str] | None = None,
) -> Run:
    """Run `rmv` as a separate process: what a user's shell sees."""
    completed = subprocess.run(
        [*RMV, *args], cwd=cwd, input=stdin, capture_output=True, text=True, timeout=120, env=env
    )
    return Run(completed.returncode, completed.stdout, completed.stderr)


def carla_scenario() -> Any:
    """examples/carla/make_recordings.py as a module: its typestore and messages."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "make_recordings", EXAMPLES / "carla" / "make_recordings.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def damaged_bag(path: Path, rogue: str = "/rogue") -> None:
    """The braking scenario as ROS 1, but: the objects topic recorded as
    std_msgs/Float64, one status message cut short, and a node (`rogue`) that the
    whitelists do not allow publishing odometry from 20 s."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores

    scenario = carla_scenario()
    store = scenario.typestore(Stores.ROS1_NOETIC)
    float64 = store.types["std_msgs/msg/Float64"]
    with Writer(path) as writer:
        status = writer.add_connection(
            scenario.STATUS, scenario.STATUS_TYPE, typestore=store, callerid=scenario.BRIDGE
        )
        objects = writer.add_connection(
            scenario.OBJECTS, "std_msgs/msg/Float64", typestore=store, callerid=scenario.BRIDGE
        )
        rogue = writer.add_connection(
            "/carla/hero/odometry", "std_msgs/msg/Float64", typestore=store, callerid=rogue
        )
        for k, (t, topic, message) in enumerate(scenario.messages(store)):
            if topic == scenario.OBJECTS:
                data = store.serialize_ros1(float64(1.0), "std_msgs/msg/Float64")
                writer.write(objects, t, data)
                continue
            data = store.serialize_ros1(message, message.__msgtype__)
            writer.write(status, t, data[:7] if k == 5 else data)
        for k in range(10):
            t = scenario.START + 20 * 10**9 + k * 10**8
            writer.write(rogue, t, store.serialize_ros1(float64(0.5), "std_msgs/msg/Float64"))


class CountingStream:
    """An output stream that counts its writes: one that writes through (as
    PYTHONUNBUFFERED=1 makes stdout) pays a system call for each."""

    def __init__(self, terminal: bool) -> None:
        self.terminal, self.writes, self.parts = terminal, 0, []

    def isatty(self) -> bool:
        return self.terminal

    def write(self, text: str) -> int:
        self.writes += 1
        self.parts.append(text)
        return len(text)

    def flush(self) -> None:
        pass


def per_property(verdicts: list[dict]) -> dict[str, list[dict]]:
    """Each property's verdict segments in the order they came: a live node decides
    each property as soon as it can, so two properties' segments interleave by when
    they were decided, which a replay (deciding at the end of its input) does not."""
    out: dict[str, list[dict]] = {}
    for verdict in verdicts:
        out.setdefault(verdict["property"], []).append(verdict)
    return out


def assert_soaked(seen: dict, seconds: float, replayed: str) -> None:
    """What a soak (tests/ros2/drive_soak.py, tests/ros1/drive_soak.py) must show:
    every report names a rogue; every rogue reported within 2 s; the node's verdict
    segments those of `replayed` (`rmv replay --format jsonl` of what was sent); both
    nodes' memory grown less than 10% after the first quarter."""
    assert seen["codes"] == [0, 0], seen.get("log", "")
    assert seen["reports"] and all("/rogue" in text for text in seen["reports"]), seen["reports"]
    latencies = seen["latencies"]
    print(f"{len(seen['sent'])} messages, {len(seen['verdicts'])} verdict segments, rogues "
          f"reported after {latencies} s")  # fmt: skip
    # Rogues start every 10 s from 5 s (5 in a minute); a slow start under load may
    # push the last past the end. A negative latency on ROS 1: the report came before
    # the driver's poll of the master listed the rogue.
    assert len(latencies) >= seconds // 14 and all(
        latency is not None and latency <= 2.0 for latency in latencies
    ), latencies  # fmt: skip
    from_replay = [json.loads(line) for line in replayed.splitlines() if '"verdict"' in line]
    from_node = [json.loads(v) for v in seen["verdicts"]]
    assert per_property(from_node) == per_property(from_replay)
    rss = seen["rss"]
    warm = rss[len(rss) // 4]
    for index in (1, 2):  # the monitor, the intrusion node
        growth = rss[-1][index] / warm[index] - 1
        print(f"RSS of node {index}: {warm[index]} KiB at {warm[0]} s, {rss[-1][index]} KiB at "
              f"{rss[-1][0]} s ({growth:+.1%})")  # fmt: skip
        assert growth < 0.10, rss
