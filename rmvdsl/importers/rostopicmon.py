"""rostopicmon's configuration (thesis 3.4) into .rmv: the database, topics,
variables, the continuous-query events, and the Kapacitor monitors as alerts."""

from __future__ import annotations

import os
import re
from typing import Any

from rmvdsl.grammar.printer import quote
from rmvdsl.importers.draft import Draft, claim, identifier, parses, short
from rmvdsl.importers.influxql import influx_expression
from rmvdsl.importers.located import Located
from rmvdsl.importers.tickscript import convert_tickscript
from rmvdsl.lang.errors import UsageError
from rmvdsl.lang.files import read_text

# Message types of the CARLA topics of thesis table 4.1 (the YAML files of
# rostopicmon name no type: it read them at run time).
KNOWN_TOPIC_TYPES = {
    "/carla/actor_list": "carla_msgs/CarlaActorList",
    "/carla/hero/gnss/front/fix": "sensor_msgs/NavSatFix",
    "/carla/hero/objects": "derived_object_msgs/ObjectArray",
    "/carla/hero/odometry": "nav_msgs/Odometry",
    "/carla/hero/vehicle_info": "carla_msgs/CarlaEgoVehicleInfo",
    "/carla/hero/vehicle_status": "carla_msgs/CarlaEgoVehicleStatus",
    "/carla/marker": "visualization_msgs/Marker",
    "/carla/objects": "derived_object_msgs/ObjectArray",
    "/carla/status": "carla_msgs/CarlaStatus",
    "/carla/world_info": "carla_msgs/CarlaWorldInfo",
    "/clock": "rosgraph_msgs/Clock",
    "/rosout": "rosgraph_msgs/Log",
    "/tf": "tf2_msgs/TFMessage",
}


UNKNOWN_TYPE = "unknown_msgs/Unknown"


_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


_NUMBER = re.compile(r"\d+(\.\d+)?")


_MESSAGE_TYPE = re.compile(r"[A-Za-z][A-Za-z0-9_]*(/msg)?/[A-Za-z][A-Za-z0-9_]*")


_NOW_RANGE = re.compile(
    r"^\s*time\s*>=?\s*now\(\)\s*-\s*(\d+(?:\.\d+)?(?:ns|u|us|ms|s|m|h|d|w))"
    r"(\s+and\s+time\s*<=?\s*now\(\))?\s*$",
    re.IGNORECASE,
)


def convert_database(document: Located, spec: Draft) -> None:
    raw = document["database"]
    settings: dict[str, Any] = {}
    where = document.where("database")
    if isinstance(raw, list):  # the thesis writes a list of one-key mappings
        for item in raw:
            if isinstance(item, dict):
                settings.update(item)
    elif isinstance(raw, dict):
        settings = dict(raw)
    lines = ["database {"]
    for key, value in settings.items():
        text = None if value is None else str(value).strip()
        if not text:
            continue
        if key == "ip":
            lines.append(f"    host = {quote(text)}")
        elif key == "port":
            lines.append(
                f"    port = {text}" if text.isdigit() else f"    // port {text!r} is not a number"
            )
        elif key == "db_name":
            lines.append(f"    name = {quote(text)}")
        elif key == "epoch":
            precision = {"n": "ns"}.get(text, text)
            if precision in ("ns", "u", "us", "ms", "s", "m", "h"):
                lines.append(f"    precision = {precision}")
            else:
                spec.note(where, f"epoch `{short(text)}` is not a precision: not carried over")
        elif key == "username":
            lines.append(f"    username = {quote(text)}")
        elif key == "password":
            lines.append('    password = env("RMV_INFLUX_PASSWORD")')
            spec.note(where, "the password is not copied into the spec: export RMV_INFLUX_PASSWORD")
        else:
            spec.note(where, f"database setting `{key}` is unknown: not carried over")
    if not any(line.startswith("    name") for line in lines):
        lines.append('    name = "rmvcps_db"')
        spec.note(where, "no `db_name`: the database is named `rmvcps_db`")
    lines.append("}")
    spec.add(spec.database, "\n".join(lines), where, "the database")


def convert_topics(topics: list[Located], spec: Draft) -> None:
    for entry in topics:
        yaml_name = str(entry.get("name") or "").strip()
        path = str(entry.get("topic") or "").strip()
        if not path:
            spec.note(entry.where(), "a topic without `topic:` (its ROS name) is skipped")
            continue
        name = claim(
            spec, identifier(yaml_name or path.rsplit("/", 1)[-1], "topic"), entry.where("name")
        )
        msg_type = str(
            entry.get("type") or entry.get("msg_type") or ""
        ).strip() or KNOWN_TOPIC_TYPES.get(path)
        if msg_type and not _MESSAGE_TYPE.fullmatch(msg_type):
            spec.note(entry.where("type"), f"`{short(msg_type)}` is not a message type")
            msg_type = ""
        if not msg_type:
            msg_type = UNKNOWN_TYPE
            spec.note(
                entry.where(),
                f"topic `{path}` has no message type in the YAML: "
                f"replace `{UNKNOWN_TYPE}` in the spec with its type",
            )
        if not spec.add(
            spec.topics, f"topic {name}: {msg_type} = {quote(path)}", entry.where(), "the topic"
        ):
            continue
        spec.topic_names[yaml_name or name] = name
        spec.topic_paths[path] = name


def convert_variables(variables: list[Located], spec: Draft) -> None:
    for entry in variables:
        where = entry.where()
        topic_ref = str(entry.get("topic") or "").strip()
        topic = spec.topic_names.get(topic_ref) or spec.topic_paths.get(topic_ref)
        if topic is None:
            spec.note(
                entry.where("topic"),
                f"variable `{entry.get('name')}` names the unknown topic "
                f"`{topic_ref}`: not carried over",
            )
            continue
        field_path = _field_path(str(entry.get("topic_var_path") or ""))
        if not field_path:
            spec.note(
                where,
                f"variable `{entry.get('name')}` has no valid `topic_var_path`: not carried over",
            )
            continue
        name = claim(spec, identifier(str(entry.get("name") or field_path), "variable"), where)
        spec.add(spec.variables, f"var {name} = {topic}.{field_path}", where, f"variable `{name}`")


def _field_path(raw: str) -> str:
    """`control/brake` -> `control.brake`; `objects/0/id` -> `objects[0].id`."""
    parts = [p for p in re.split(r"[/.]", raw.strip()) if p]
    out: list[str] = []
    for part in parts:
        if (part.isdigit() or part == "*") and out:
            out[-1] += f"[{part}]"
        elif _IDENT.fullmatch(part):
            out.append(part)
        else:
            return ""
    return ".".join(out)


def convert_events(events: list[Located], spec: Draft) -> None:
    for entry in events:
        name = claim(spec, identifier(str(entry.get("event_name") or ""), "event"), entry.where())
        select = str(entry.get("event_select") or "").strip()
        if not select:
            spec.note(entry.where(), f"event `{name}` has no `event_select`: not carried over")
            continue
        lines = [f"event {name} = {influx_expression(select)}"]
        lines += _event_clauses(entry, spec)
        candidate = "\n".join(lines)
        if not parses(candidate):
            spec.note(
                entry.where("event_select"),
                f"event `{name}`: `{select}` is not an expression rmvdsl reads: not carried over",
            )
            continue
        spec.events.append(candidate)


def _event_clauses(entry: Located, spec: Draft) -> list[str]:
    clauses = []
    where = str(entry.get("event_where") or "").strip()
    if where:
        clauses.append(f"    where {influx_expression(where)}")
    resample = str(entry.get("event_resample") or "").strip()
    if resample:
        clauses.append("    resample " + _resample(resample, entry, spec))
    range_text = str(entry.get("event_range") or "").strip()
    if range_text:
        match = _NOW_RANGE.match(range_text)
        if match:
            clauses.append(f"    range {match.group(1)}")
        else:
            spec.note(
                entry.where("event_range"),
                f"range `{range_text}` is not of the form "
                "`time >= now() - D AND time < now()`: not carried over",
            )
    group = str(entry.get("event_groupby") or "").strip()
    if group:
        clauses.append(f"    group by {influx_expression(group)}")
    fill = str(entry.get("event_fill") or "").strip()
    if fill:
        if _IDENT.fullmatch(fill) or _NUMBER.fullmatch(fill):
            clauses.append(f"    fill {fill.lower()}")
        else:
            spec.note(entry.where("event_fill"), f"fill `{short(fill)}` not read")
    order = str(entry.get("event_orderby") or "").strip()
    if order:
        direction = order.split()[-1].lower()
        if direction in ("asc", "desc"):
            clauses.append(f"    order {direction}")
        else:
            spec.note(entry.where("event_orderby"), f"order `{short(order)}` not read")
    limit = str(entry.get("event_limit_size") or "").strip()
    if limit:
        if limit.isdigit():
            clauses.append(f"    limit {limit}")
        else:
            spec.note(entry.where("event_limit_size"), f"limit `{short(limit)}` not read")
    return clauses


def _resample(text: str, entry: Located, spec: Draft) -> str:
    words = text.split()
    parts = []
    for keyword, value in zip(words[::2], words[1::2], strict=False):
        if keyword.upper() in ("EVERY", "FOR"):
            parts.append(f"{keyword.lower()} {value}")
    if parts:
        return " ".join(parts)
    spec.note(
        entry.where("event_resample"),
        f"`event_resample: {text}` has no FOR/EVERY: read as `every {text}`",
    )
    return f"every {text}"


def convert_kapacitor_monitor(path: str, monitor: Located, spec: Draft) -> None:
    name = identifier(str(monitor.get("monitor_name") or "monitor"), "monitor")
    tick = str(monitor.get("monitor_specification") or "").strip()
    if not tick:
        spec.note(monitor.where(), f"monitor `{name}` names no TICKscript: not carried over")
        return
    tick_path = os.path.join(os.path.dirname(path), tick)
    try:
        script = read_text(tick_path)
    except UsageError as exc:
        spec.note(
            monitor.where("monitor_specification"),
            f"monitor `{name}`: {exc}; its alert is not carried over",
        )
        return
    alert, notes = convert_tickscript(script, claim(spec, name, monitor.where()))
    for note in notes:
        spec.note(tick_path, note)
    if alert:
        spec.add(spec.alerts, alert, monitor.where(), f"the alert of `{name}`")
