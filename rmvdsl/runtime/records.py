"""What the runtime gives out: records (one JSON object each, times as exact
decimals), the context of an action and the hosts that take actions."""

from __future__ import annotations

import json
import math
from fractions import Fraction
from typing import Any, NamedTuple, Protocol

from rmvdsl.runtime import influx
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.values import exact_decimal

NS = influx.NS
Record = dict[str, Any]


def seconds(ns: int) -> Fraction:
    """`ns` nanoseconds in seconds, exactly."""
    return Fraction(ns, NS)


class Host(Protocol):
    """What a host (the replay, the ROS node) does with an action."""

    def act(self, action: ir.Action, context: ActionContext) -> None: ...


class ActionContext(NamedTuple):  # made per action taken: a tuple, the cheapest
    owner_kind: str  # property | alert | intrusion | whitelist | node
    owner: str
    level: str  # a log level: debug, info, warn, error, fatal
    message: str  # the action's message, or the owner's
    record: Record  # what happened, as the runtime reports it


class RecordingHost:
    """Actions as records only: nothing leaves the process."""

    def __init__(self) -> None:
        self.records: list[Record] = []

    def act(self, action: ir.Action, context: ActionContext) -> None:
        self.records.append(action_record(action, context))


def action_record(action: ir.Action, context: ActionContext) -> Record:
    out: Record = {
        "kind": "action",
        "action": action.TAG,
        "owner": context.owner,
        "owner_kind": context.owner_kind,
        "time": context.record.get("time", context.record.get("from")),
        "message": context.message,
    }
    if isinstance(action, ir.Log):
        out["level"] = context.level
    elif isinstance(action, ir.Publish):
        out["topic"] = action.topic
    elif isinstance(action, ir.Post):
        out["url"] = action.url
    elif isinstance(action, ir.Exec):
        out["command"] = [action.command, *action.args]
    elif isinstance(action, ir.Tcp):
        out["address"] = action.address
    return out


def action_text(action: ir.Action, default: str) -> str:
    message = getattr(action, "message", None)
    return message if message is not None else default


def action_level(action: ir.Action, default: str) -> str:
    level = getattr(action, "level", None)
    return level if level is not None else default


def to_json(record: Record) -> str:
    """One record as one line of JSON; times and other fractions as exact decimals
    (a quotient such as "1/3" as a string where no decimal is exact), floats that
    JSON cannot hold as strings ("nan", "inf", "-inf")."""
    return _json_object(record) if type(record) is dict else _json_value(record)


def _json_value(value: Any) -> str:
    kind = type(value)
    if kind is str:
        return _json_string(value)
    if kind is Fraction:
        return _fraction(value)
    if kind is bool or value is None:
        return "true" if value is True else "false" if value is False else "null"
    if kind is int:
        return str(value)
    if kind is float:
        return repr(value) if math.isfinite(value) else f'"{value!r}"'
    if kind is dict or isinstance(value, dict):
        return _json_object(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join([_json_value(v) for v in value]) + "]"
    return _json_string(str(value))


def _json_object(value: dict[Any, Any]) -> str:
    """`_json_value` of a dict (every record): its keys written once per shape
    (records come in few), the values records mostly hold (names, times, numbers)
    written in line, a call fewer for each."""
    texts = []
    for item in value.values():
        kind = type(item)
        if kind is str:
            texts.append(_json_string(item))
        elif kind is Fraction:  # a time, mostly
            texts.append(_fraction(item))
        elif kind is float and math.isfinite(item):
            texts.append(repr(item))
        else:
            texts.append(_json_value(item))
    shape = tuple(value)
    template = _SHAPES.get(shape)
    if template is None:
        template = _shape(shape)
    return template % tuple(texts)


def _fraction(value: Fraction) -> str:
    """An exact decimal, or the quotient as a string where no decimal is exact."""
    text = exact_decimal(value)
    return text if text is not None else f'"{value}"'


def _shape(keys: tuple[Any, ...]) -> str:
    """The text of an object with `keys`, a `%s` for each value. Only shapes of
    text keys are kept: `(1,)` equals `(True,)`, which writes its key otherwise."""
    text = "{" + ", ".join(_key(k).replace("%", "%%") + ": %s" for k in keys) + "}"
    if len(_SHAPES) < 1024 and all(type(k) is str for k in keys):
        _SHAPES[keys] = text
    return text


_SHAPES: dict[tuple[Any, ...], str] = {}


# What json.JSONEncoder(ensure_ascii=False).encode does with a str, less its wrapper.
_json_string = json.encoder.encode_basestring


def _key(key: Any) -> str:
    return _json_string(str(key))
