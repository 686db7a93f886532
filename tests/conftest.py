from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
FIXTURES = Path(__file__).resolve().parent / "fixtures"

# The solver's answer cache: one per test session (shared with the processes the
# tests start), never the user's.
os.environ["RMV_CACHE_DIR"] = tempfile.mkdtemp(prefix="rmv-cache-")


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


def rmv_process(args: Sequence[str], cwd: Path = ROOT, stdin: str | None = None) -> Run:
    """Run `rmv` as a separate process: what a user's shell sees."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    completed = subprocess.run(
        [sys.executable, "-m", "rmvdsl.cli", *args],
        cwd=cwd,
        input=stdin,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    return Run(completed.returncode, completed.stdout, completed.stderr)
