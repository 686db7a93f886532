"""The actions that leave the process — `exec`, `post`, `tcp` — done one way for
every host (the replay with --run-actions, the ROS 2 node). Standard library only.

Each sends the record that caused the action as JSON: on the program's standard
input (no shell: the arguments are data, never parsed), as an HTTP POST body, or as
one line on a TCP connection.
"""

from __future__ import annotations

import socket
import subprocess
import urllib.request

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Record, to_json

EXEC_TIMEOUT = 30.0  # seconds a program may run
TCP_TIMEOUT = 10.0


def leaves_the_process(action: ir.Action) -> bool:
    return isinstance(action, ir.Exec | ir.Post | ir.Tcp)


def perform(action: ir.Action, record: Record) -> str | None:
    """Do an exec, post or tcp action for `record`; the error, or None."""
    payload = to_json(record).encode()
    try:
        if isinstance(action, ir.Exec):
            subprocess.run(
                [action.command, *action.args], input=payload, timeout=EXEC_TIMEOUT, check=False
            )
        elif isinstance(action, ir.Post):
            request = urllib.request.Request(
                action.url, data=payload, headers={"Content-Type": "application/json"}
            )
            urllib.request.urlopen(request, timeout=float(action.timeout)).close()
        elif isinstance(action, ir.Tcp):
            host, _, port = action.address.rpartition(":")
            with socket.create_connection((host, int(port)), timeout=TCP_TIMEOUT) as connection:
                connection.sendall(payload + b"\n")
    except (OSError, ValueError, subprocess.SubprocessError) as error:
        return str(error)
    return None
