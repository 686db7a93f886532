"""Worker processes of rmvdsl's own: this Python running one of rmvdsl's modules as a
program, importing the very rmvdsl this process runs (a checkout or an install,
whatever the worker's folder), never a fork of the command."""

from __future__ import annotations

import os
import sys
from pathlib import Path


def module_command(module: str) -> tuple[list[str], dict[str, str]]:
    """The command line and environment that run `python -m module` so."""
    package_root = str(Path(__file__).resolve().parents[2])
    path = os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH")) if p)
    return [sys.executable, "-m", module], {**os.environ, "PYTHONPATH": path}
