"""rmvdsl's modules as an install holds them: compiled."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def byte_compile() -> None:
    """rmvdsl's modules compiled once before anything is timed, as pip compiles a
    wheel it installs: a source tree under PYTHONDONTWRITEBYTECODE would otherwise
    compile every module in every timed process (0.13 s of `rmv eval`'s start)."""
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(ROOT / "rmvdsl")], check=True)
