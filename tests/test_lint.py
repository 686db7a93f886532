"""The code stays ruff- and mypy-clean (both are dev dependencies)."""

from __future__ import annotations

import subprocess
import sys

from conftest import ROOT

PATHS = ["rmvdsl", "tests", "benchmarks", "examples"]


def run(*command: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)


def test_ruff_check_and_format():
    # ruff and mypy are dev dependencies: `pip install -e '.[dev]'` installs both.
    # As a module of this interpreter: a venv's bin folder need not be on PATH.
    check = run(sys.executable, "-m", "ruff", "check", *PATHS)
    assert check.returncode == 0, check.stdout + check.stderr
    formatted = run(sys.executable, "-m", "ruff", "format", "--check", *PATHS)
    assert formatted.returncode == 0, formatted.stdout


def test_mypy():
    result = run(sys.executable, "-m", "mypy")
    assert result.returncode == 0, result.stdout
