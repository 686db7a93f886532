"""A process's CPU time and peak memory, measured without the measuring process's.

`os.wait4` on a child reports a peak RSS that starts from the process it was
started from: Python's subprocess starts children by vfork, and the kernel carries
the parent's peak into the child's at exec (with fork, the parent's size at the
fork). A benchmark that had read a large output reported its own 1.3 GB for every
later process. So each measured command is started by a small launcher (a Python
of about 9 MB, the floor of every figure), which forks it, waits for it and
reports what the kernel counted for it alone.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from typing import IO, Any

LAUNCHER = r"""
import os, sys
report = int(sys.argv[1])
child = os.fork()
if child == 0:
    os.close(report)
    try:
        os.execvp(sys.argv[2], sys.argv[2:])
    finally:
        os._exit(127)
_, status, usage = os.wait4(child, 0)
os.write(report, f"{usage.ru_utime} {usage.ru_stime} {usage.ru_maxrss}".encode())
code = os.waitstatus_to_exitcode(status)
os._exit(code if code >= 0 else 128 - code)
"""


@dataclass(frozen=True)
class Usage:
    cpu: float  # user and system seconds
    peak_bytes: int
    returncode: int
    stderr: str


def run(command: list[str], stdout: IO[Any] | int | None = None, **options: Any) -> Usage:
    """Run `command` to its end (options as subprocess.Popen's) and say what it used."""
    read, write = os.pipe()
    try:
        process = subprocess.Popen(
            [sys.executable, "-c", LAUNCHER, str(write), *command],
            stdout=stdout,
            stderr=subprocess.PIPE,
            pass_fds=(write,),
            **options,
        )
        os.close(write)
        write = -1
        _, error = process.communicate()
        with os.fdopen(read, "rb") as pipe:
            read = -1
            report = pipe.read().decode().split()
    finally:
        for fd in (read, write):
            if fd >= 0:
                os.close(fd)
    if len(report) != 3:
        raise SystemExit(f"{command[:4]} did not start: {error.decode(errors='replace')}")
    user, system, peak_kb = report
    return Usage(float(user) + float(system), int(peak_kb) * 1024, process.returncode,
                 error.decode(errors="replace"))  # fmt: skip
