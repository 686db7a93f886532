"""Records as lines for a person: what `rmv replay` prints as text, and what the
HTML report lists under its drawing."""

from __future__ import annotations

import shlex
from fractions import Fraction
from typing import Any

from rmvdsl.runtime.engine import Record
from rmvdsl.runtime.values import exact_text


def decimal_text(value: Any) -> str:
    """A time or value as a person reads it: an exact decimal where it is one."""
    return exact_text(value) if isinstance(value, Fraction) else str(value)


def text_line(record: Record) -> str | None:
    """One record as a line for a person, or None for records only JSON carries."""
    kind = record["kind"]
    if kind == "verdict":
        open_, close = record["bounds"]
        span = f"{open_}{decimal_text(record['from'])}, {decimal_text(record['to'])}{close}"
        revised = " (revised: late input)" if record.get("revised") else ""
        return f"verdict   {record['property']}: {record['verdict']} on {span}{revised}"
    if kind == "alert":
        if record["level"] == record["previous"]:
            return None  # a repeat at the same level: JSON has every point, text the changes
        values = ", ".join(f"{k}={decimal_text(v)}" for k, v in record["values"].items())
        return (
            f"alert     {decimal_text(record['time'])} {record['alert']}: {record['previous']} -> "
            f"{record['level']}: {record['message']} ({values})"
        )
    if kind == "intrusion":
        what = "intrusion" if record["phase"] == "start" else "ended"
        return (
            f"{what:<9} {decimal_text(record['time'])} {record['node']} as {record['role']} of "
            f"{record['topic']}: {record['reason']}"
        )
    if kind == "state":
        return (
            f"state     {decimal_text(record['time'])} {record['transducer']} -> {record['state']}"
        )
    if kind == "action":
        return _action_line(record)
    if kind == "diagnostic":
        where = f"{record['origin']}: " if record.get("origin") else ""
        return f"warning   {decimal_text(record['time'])} {where}{record['message']}"
    if kind == "counter":
        return f"counter   {record['name']}: {record['value']}"
    return None


def _action_line(record: dict[str, Any]) -> str:
    """An action: what it does (the program and its arguments, the URL, the address,
    the topic, the level), its message, and with --run-actions whether it ran."""
    command = record.get("command")
    target = (
        " ".join(shlex.quote(str(part)) for part in command)
        if command
        else record.get("topic") or record.get("url") or record.get("address") or ""
    )
    level = record.get("level", "")
    line = f"action    {decimal_text(record['time'])} {record['action']} {level}{target}: "
    line += record["message"]
    if record.get("error"):
        return f"{line}  FAILED: {record['error']}"
    return f"{line}  (ran)" if record.get("ran") else line
