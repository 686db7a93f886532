"""The actions that leave the process — `exec`, `post`, `tcp` — done one way for
every host (the replay with --run-actions, the ROS 2 node). Standard library only.

Each sends the record that caused the action as JSON: on the program's standard
input (no shell: the arguments are data, never parsed), as an HTTP POST body, or as
one line on a TCP connection.
"""

from __future__ import annotations

import socket
import subprocess
import urllib.error
import urllib.request

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Record, to_json
from rmvdsl.runtime.wording import os_words

EXEC_TIMEOUT = 30.0  # seconds a program may run
TCP_TIMEOUT = 10.0


def leaves_the_process(action: ir.Action) -> bool:
    return isinstance(action, ir.Exec | ir.Post | ir.Tcp)


def perform(action: ir.Action, record: Record) -> str | None:
    """Do an exec, post or tcp action for `record`; what went wrong, in words, or
    None."""
    payload = to_json(record).encode()
    try:
        if isinstance(action, ir.Exec):
            return _run(action, payload)
        if isinstance(action, ir.Post):
            request = urllib.request.Request(
                action.url, data=payload, headers={"Content-Type": "application/json"}
            )
            urllib.request.urlopen(request, timeout=float(action.timeout)).close()
        elif isinstance(action, ir.Tcp):
            host, _, port = action.address.rpartition(":")
            with socket.create_connection((host, int(port)), timeout=TCP_TIMEOUT) as connection:
                connection.sendall(payload + b"\n")
    except urllib.error.HTTPError as error:
        return f"the server answered {error.code} {error.reason}"
    except urllib.error.URLError as error:
        reason = error.reason
        return _network(reason) if isinstance(reason, OSError) else f"cannot post: {reason}"
    except (OSError, ValueError) as error:
        return _network(error)
    return None


def _run(action: ir.Exec, payload: bytes) -> str | None:
    """The program, with the record on its standard input; a failure in words."""
    try:
        done = subprocess.run([action.command, *action.args], input=payload,
                              timeout=EXEC_TIMEOUT, check=False)  # fmt: skip
    except FileNotFoundError:
        return f"no such program: {action.command}"
    except PermissionError:
        return f"not allowed to run {action.command}"
    except subprocess.TimeoutExpired:
        return f"{action.command} ran longer than {EXEC_TIMEOUT:g} s and was stopped"
    except OSError as error:
        return f"cannot run {action.command}: {_network(error)}"
    if done.returncode != 0:
        return f"{action.command} exited with code {done.returncode}"
    return None


def _network(error: Exception) -> str:
    """A connection's failure in words (not `[Errno 111] Connection refused`)."""
    if isinstance(error, socket.gaierror):
        return "unknown host"
    if isinstance(error, OSError):
        return os_words(error)
    return f"not an address: {error}"
