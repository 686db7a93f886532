"""Where rmvdsl keeps files between processes (solver answers, checks, compiled
code): one folder, chosen by the environment."""

from __future__ import annotations

import os


def cache_folder() -> str | None:
    """Where rmvdsl keeps files between processes: `RMV_CACHE_DIR`, else
    `$XDG_CACHE_HOME/rmvdsl` or `~/.cache/rmvdsl`; None when RMV_CACHE_DIR is empty."""
    folder = os.environ.get("RMV_CACHE_DIR")
    if folder is None:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        folder = os.path.join(base, "rmvdsl")
    return folder or None
