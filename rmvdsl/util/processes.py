"""Worker processes of rmvdsl's own: this Python running one of rmvdsl's modules as a
program, importing the very rmvdsl this process runs (a checkout or an install,
whatever the worker's folder), never a fork of the command."""

from __future__ import annotations

import os
import struct
import sys
from pathlib import Path
from typing import IO


def module_command(module: str) -> tuple[list[str], dict[str, str]]:
    """The command line and environment that run `python -m module` so."""
    package_root = str(Path(__file__).resolve().parents[2])
    path = os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH")) if p)
    return [sys.executable, "-m", module], {**os.environ, "PYTHONPATH": path}


def write_frame(stream: IO[bytes], payload: bytes) -> None:
    """One message on a pipe to or from such a worker: its length, then itself."""
    stream.write(struct.pack("<Q", len(payload)) + payload)
    stream.flush()


def read_frame(stream: IO[bytes]) -> bytes | None:
    """The next message of `write_frame`; None once the pipe ends."""
    header = stream.read(8)
    if len(header) < 8:
        return None
    (size,) = struct.unpack("<Q", header)
    payload = stream.read(size)
    return payload if len(payload) == size else None
