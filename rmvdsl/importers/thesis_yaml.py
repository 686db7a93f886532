"""`rmv import`: the thesis's YAML configurations to one .rmv spec.

Reads the formats of rostopicmon (thesis 3.4.6: database, topics, variables,
events, monitors), rostopicver (3.5: states, initial, transitions, rmtld3synth
monitors) and rostopicintrusion (topics with publishers and subscribers; the
thesis does not print this file, docs/import.md gives the format read here).
Anchors and aliases are resolved by YAML itself. Whatever cannot be carried over
is reported as a note with its file:line:column.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import yaml

from rmvdsl.check.loader import UsageError, read_text
from rmvdsl.grammar.formatter import format_spec
from rmvdsl.grammar.parser import parse_source
from rmvdsl.grammar.printer import quote
from rmvdsl.importers.influxql import influx_expression
from rmvdsl.importers.tickscript import convert_tickscript
from rmvdsl.lang.render import visible
from rmvdsl.lang.source import SourceFile
from rmvdsl.runtime.wording import counted

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


class Located(dict[str, Any]):
    """A YAML mapping that remembers where it and each of its keys stand."""

    path: str = ""
    line: int = 0
    column: int = 0
    key_marks: dict[str, tuple[int, int]]

    def where(self, key: str | None = None) -> str:
        line, column = (
            self.key_marks.get(key, (self.line, self.column)) if key else (self.line, self.column)
        )
        return f"{self.path}:{line}:{column}"


def _loader_for(path: str) -> type[yaml.SafeLoader]:
    class Loader(yaml.SafeLoader):
        pass

    def construct_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode) -> Located:
        raw = loader.construct_mapping(node, deep=True)
        mapping = Located({str(key): value for key, value in raw.items()})
        mapping.path = path
        mapping.line, mapping.column = node.start_mark.line + 1, node.start_mark.column + 1
        mapping.key_marks = {
            str(key.value): (key.start_mark.line + 1, key.start_mark.column + 1)
            for key, _ in node.value
        }
        return mapping

    Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    return Loader


# YAML's aliases can multiply a small file into billions of values (nine levels of
# `&a [*a, *a, ...]`): the nodes are counted as the aliases are followed, before
# anything is built, and a document past this size is refused.
MAX_NODES = 100_000


def load_yaml(path: str) -> Any:
    text = read_text(path)
    try:
        loader = _loader_for(path)(text)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            _check_size(node, path)
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"{path}:{mark.line + 1}:{mark.column + 1}" if mark else path
        problem = exc.problem or exc.context or "invalid YAML"
        raise UsageError(f"{where}: {problem}") from None
    except yaml.YAMLError as exc:
        raise UsageError(f"{path}: invalid YAML: {exc}") from None


def _check_size(root: yaml.Node, path: str) -> None:
    count = 0
    stack: list[yaml.Node] = [root]
    while stack:
        node = stack.pop()
        count += 1
        if count > MAX_NODES:
            mark = node.start_mark
            raise UsageError(
                f"{path}:{mark.line + 1}:{mark.column + 1}: the document expands to more than "
                f"{counted(MAX_NODES, 'value', grouped=True)} "
                "(aliases repeated inside aliases): refused"
            )
        if isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
        elif isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                stack += [key, value]


@dataclass
class ImportResult:
    text: str
    notes: list[str] = field(default_factory=list)


@dataclass
class _Spec:
    """The .rmv being written, as lists of declaration texts by section."""

    header: list[str] = field(default_factory=list)
    database: list[str] = field(default_factory=list)
    topics: list[str] = field(default_factory=list)
    variables: list[str] = field(default_factory=list)
    events: list[str] = field(default_factory=list)
    transducers: list[str] = field(default_factory=list)
    properties: list[str] = field(default_factory=list)
    alerts: list[str] = field(default_factory=list)
    whitelists: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    topic_names: dict[str, str] = field(default_factory=dict)  # YAML name -> .rmv name
    topic_paths: dict[str, str] = field(default_factory=dict)  # ROS name -> .rmv name
    names: set[str] = field(default_factory=set)

    def note(self, where: str, message: str) -> None:
        self.notes.append(visible(f"{where}: {message}"))

    def add(self, section: list[str], text: str, where: str, what: str) -> bool:
        """Add one declaration, if it is exactly one declaration of .rmv: whatever
        a YAML value holds (a newline, a quote, `property Injected: true`) can never
        add another one."""
        if _parses(text):
            section.append(text)
            return True
        self.note(where, f"{what} does not make valid .rmv: not carried over")
        return False

    def text(self) -> str:
        sections = [
            self.header,
            self.database,
            self.topics,
            self.variables,
            self.events,
            self.transducers,
            self.properties,
            self.alerts,
            self.whitelists,
        ]
        return "\n\n".join("\n".join(s) for s in sections if s) + "\n"


def convert_files(paths: Iterable[str], system_name: str | None = None) -> ImportResult:
    spec = _Spec()
    documents = [(path, load_yaml(path)) for path in paths]
    name = system_name or _identifier(
        os.path.splitext(os.path.basename(documents[0][0]))[0], "imported"
    )
    sources = ", ".join(os.path.basename(p) for p, _ in documents)
    spec.header.append(f"/// Imported by `rmv import` from {sources}.")
    spec.header.append(f"system {name}")
    spec.header.append("")
    spec.header.append("// rmtld3synth formulas count time in seconds.")
    spec.header.append("time unit s")
    spec.header.append("")
    spec.header.append("// The thesis's nodes ran on ROS 1.")
    spec.header.append("ros noetic")
    for path, document in documents:
        if not isinstance(document, Located):
            raise UsageError(
                f"{path}: expected a YAML mapping at the top, found {type(document).__name__}"
            )
        _convert_document(path, document, spec)
    text = _canonical(spec.text(), spec)
    _report_open_names(text, spec)
    return ImportResult(text, spec.notes)


def _report_open_names(text: str, spec: _Spec) -> None:
    """Names the YAML files use but do not define (the thesis's examples do)."""
    from rmvdsl.check.loader import load
    from rmvdsl.check.names import check_names

    loaded = load("<import>", text)
    _, diagnostics = check_names(loaded.specs, loaded.sources, loaded.damaged_names)
    undefined = sorted({text[d.span.start : d.span.end] for d in diagnostics if d.code == "RMV200"})
    if undefined:
        spec.note(
            "<output>",
            "used but not defined in these files: "
            + ", ".join(undefined)
            + "; declare them (boolean events or transducer states) before `rmv check` passes",
        )


def _canonical(text: str, spec: _Spec) -> str:
    source = SourceFile("<import>", text)
    parsed = parse_source(source)
    errors = [d for d in parsed.diagnostics if d.is_error]
    if errors:
        for diagnostic in errors:
            line = source.position(diagnostic.span.start).line
            spec.note("<output>", f"line {line}: {diagnostic.message} (left as written)")
        return text
    return format_spec(parsed.spec, source)


def _convert_document(path: str, document: Located, spec: _Spec) -> None:
    known = {
        "database",
        "topics",
        "variables",
        "events",
        "monitors",
        "states",
        "initial",
        "transitions",
        "whitelist",
        "whitelists",
        "nodes",
    }
    for key in document:
        if key not in known:
            spec.note(document.where(key), f"unknown section `{key}`, not carried over")
    if "database" in document:
        _database(document, spec)
    topics = _entries(document.get("topics"), spec, document, "topics")
    if _is_intrusion_list(topics):
        _whitelists(topics, spec)
    else:
        _topics(topics, spec)
    for key in ("whitelist", "whitelists"):
        _whitelists(_entries(document.get(key), spec, document, key), spec)
    _nodes(_entries(document.get("nodes"), spec, document, "nodes"), spec)
    _variables(_entries(document.get("variables"), spec, document, "variables"), spec)
    _events(_entries(document.get("events"), spec, document, "events"), spec)
    if "states" in document or "transitions" in document:
        _transducer(path, document, spec)
    for monitor in _entries(document.get("monitors"), spec, document, "monitors"):
        generator = str(monitor.get("monitor_gen", "")).strip()
        if generator == "kapacitor":
            _kapacitor_monitor(path, monitor, spec)
        elif generator in ("rmtld3synth", "rtmld3synth"):
            _rmtld3_monitor(monitor, spec)
        else:
            spec.note(
                monitor.where("monitor_gen"),
                f"monitor generator `{generator}` is unknown; "
                "expected `kapacitor` or `rmtld3synth`: monitor not carried over",
            )


def _entries(value: Any, spec: _Spec, parent: Located, key: str) -> list[Located]:
    if value is None:
        return []
    if not isinstance(value, list):
        spec.note(parent.where(key), f"`{key}` should be a list: not carried over")
        return []
    entries = []
    for item in value:
        if isinstance(item, Located):
            entries.append(item)
        elif item is not None:
            spec.note(
                parent.where(key),
                f"an entry of `{key}` is not a mapping: `{_short(item)}` skipped",
            )
    return entries


def _scalars(value: Any, spec: _Spec, parent: Located, key: str) -> list[str]:
    """A list of plain values (`states: [A, B]`); anything else is noted."""
    if value is None:
        return []
    if not isinstance(value, list):
        spec.note(parent.where(key), f"`{key}` should be a list, not `{_short(value)}`")
    items = value if isinstance(value, list) else [value]
    out = []
    for item in items:
        if isinstance(item, str | int | float) and not isinstance(item, bool):
            out.append(str(item))
        elif item is not None:
            spec.note(parent.where(key), f"`{key}` holds `{_short(item)}`, not a name: skipped")
    return out


def _short(value: Any) -> str:
    text = " ".join(repr(value).split())
    return text if len(text) <= 40 else text[:37] + "..."


def _identifier(text: str, fallback: str) -> str:
    cleaned = re.sub(r"[^A-Za-z0-9_]", "_", text.strip())
    if not cleaned:
        return fallback
    return cleaned if not cleaned[0].isdigit() else "_" + cleaned


def _claim(spec: _Spec, wanted: str, where: str) -> str:
    name = wanted
    counter = 2
    while name in spec.names:
        name = f"{wanted}_{counter}"
        counter += 1
    if name != wanted:
        spec.note(where, f"`{wanted}` is used twice: the second is renamed `{name}`")
    spec.names.add(name)
    return name


# ---- rostopicmon ----


def _database(document: Located, spec: _Spec) -> None:
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
                spec.note(where, f"epoch `{_short(text)}` is not a precision: not carried over")
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


def _topics(topics: list[Located], spec: _Spec) -> None:
    for entry in topics:
        yaml_name = str(entry.get("name") or "").strip()
        path = str(entry.get("topic") or "").strip()
        if not path:
            spec.note(entry.where(), "a topic without `topic:` (its ROS name) is skipped")
            continue
        name = _claim(
            spec, _identifier(yaml_name or path.rsplit("/", 1)[-1], "topic"), entry.where("name")
        )
        msg_type = str(
            entry.get("type") or entry.get("msg_type") or ""
        ).strip() or KNOWN_TOPIC_TYPES.get(path)
        if msg_type and not _MESSAGE_TYPE.fullmatch(msg_type):
            spec.note(entry.where("type"), f"`{_short(msg_type)}` is not a message type")
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


def _variables(variables: list[Located], spec: _Spec) -> None:
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
        name = _claim(spec, _identifier(str(entry.get("name") or field_path), "variable"), where)
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


def _events(events: list[Located], spec: _Spec) -> None:
    for entry in events:
        name = _claim(spec, _identifier(str(entry.get("event_name") or ""), "event"), entry.where())
        select = str(entry.get("event_select") or "").strip()
        if not select:
            spec.note(entry.where(), f"event `{name}` has no `event_select`: not carried over")
            continue
        lines = [f"event {name} = {influx_expression(select)}"]
        lines += _event_clauses(entry, spec)
        candidate = "\n".join(lines)
        if not _parses(candidate):
            spec.note(
                entry.where("event_select"),
                f"event `{name}`: `{select}` is not an expression rmvdsl reads: not carried over",
            )
            continue
        spec.events.append(candidate)


def _event_clauses(entry: Located, spec: _Spec) -> list[str]:
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
            spec.note(entry.where("event_fill"), f"fill `{_short(fill)}` not read")
    order = str(entry.get("event_orderby") or "").strip()
    if order:
        direction = order.split()[-1].lower()
        if direction in ("asc", "desc"):
            clauses.append(f"    order {direction}")
        else:
            spec.note(entry.where("event_orderby"), f"order `{_short(order)}` not read")
    limit = str(entry.get("event_limit_size") or "").strip()
    if limit:
        if limit.isdigit():
            clauses.append(f"    limit {limit}")
        else:
            spec.note(entry.where("event_limit_size"), f"limit `{_short(limit)}` not read")
    return clauses


def _resample(text: str, entry: Located, spec: _Spec) -> str:
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


def _parses(declaration: str) -> bool:
    parsed = parse_source(SourceFile("<check>", declaration))
    return not any(d.is_error for d in parsed.diagnostics) and len(parsed.spec.items) == 1


def _kapacitor_monitor(path: str, monitor: Located, spec: _Spec) -> None:
    name = _identifier(str(monitor.get("monitor_name") or "monitor"), "monitor")
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
    alert, notes = convert_tickscript(script, _claim(spec, name, monitor.where()))
    for note in notes:
        spec.note(tick_path, note)
    if alert:
        spec.add(spec.alerts, alert, monitor.where(), f"the alert of `{name}`")


# ---- rostopicver ----


def _transducer(path: str, document: Located, spec: _Spec) -> None:
    name = _claim(
        spec,
        _identifier(os.path.splitext(os.path.basename(path))[0].title().replace("_", ""), "States"),
        document.where("states"),
    )
    states = [
        _identifier(s, "state") for s in _scalars(document.get("states"), spec, document, "states")
    ]
    initials = _scalars(document.get("initial"), spec, document, "initial")
    initial = initials[0] if initials else None
    lines = [f"transducer {name} {{"]
    if states:
        lines.append("    states " + ", ".join(states))
    if initial is not None:
        lines.append(f"    initial {_identifier(str(initial), 'state')}")
    for entry in _entries(document.get("transitions"), spec, document, "transitions"):
        source, dest = entry.get("source"), entry.get("dest")
        event = entry.get("inputtapeEvent")
        if not (source and dest and event):
            spec.note(
                entry.where(), "a transition needs `source`, `dest` and `inputtapeEvent`: skipped"
            )
            continue
        source_state, dest_state = _identifier(str(source), "s"), _identifier(str(dest), "s")
        text = f"    {source_state} -> {dest_state} on {_identifier(str(event), 'e')}"
        output = entry.get("outputtapeEvent")
        if output:
            text += f" emit {_identifier(str(output), 'e')}"
        lines.append(text)
    lines.append("}")
    if spec.add(spec.transducers, "\n".join(lines), document.where("states"), "the transducer"):
        spec.names.update(states)


def _rmtld3_monitor(monitor: Located, spec: _Spec) -> None:
    name = _claim(
        spec,
        _identifier(str(monitor.get("monitor_name") or "property"), "property"),
        monitor.where(),
    )
    expression = " ".join(str(monitor.get("expression_string") or "").split())
    if not expression:
        spec.note(monitor.where(), f"monitor `{name}` has no `expression_string`: not carried over")
        return
    members = []
    rate = str(monitor.get("monitor_rate") or "").strip()
    if rate:
        members.append(
            f"    rate = {rate}Hz" if _NUMBER.fullmatch(rate) else f"    // rate {rate!r} not read"
        )
    trigger = str(monitor.get("monitor_trigger") or "").strip()
    if trigger and trigger.lower() != "true":
        members.append(f"    trigger = {_identifier(trigger, 'always')}")
    elif trigger:
        members.append("    trigger = always")
    window = str(monitor.get("monitor_range") or "").strip()
    if window:
        match = _NOW_RANGE.match(window)
        if match:
            members.append(f"    window = {match.group(1)}")
        else:
            spec.note(
                monitor.where("monitor_range"), f"range `{window}` not read: not carried over"
            )
    block = " {\n" + "\n".join(members) + "\n}" if members else ""
    spec.add(
        spec.properties,
        f"property {name}: latex {quote(expression)}{block}",
        monitor.where(),
        f"property `{name}`",
    )


# ---- rostopicintrusion ----


def _is_intrusion_list(topics: Any) -> bool:
    return isinstance(topics, list) and any(
        isinstance(t, dict) and ("publishers" in t or "subscribers" in t) for t in topics
    )


def _patterns(value: Any) -> list[str] | None:
    if value is None:
        return None
    items = value if isinstance(value, list) else [value]
    return [str(v).strip() for v in items if v is not None and str(v).strip()]


def _pattern_line(keyword: str, patterns: list[str] | None) -> str | None:
    if patterns is None:
        return None
    return f"    {keyword}: " + (", ".join(quote(p) for p in patterns) if patterns else "none")


def _whitelists(entries: list[Located], spec: _Spec) -> None:
    for entry in entries:
        topic = str(entry.get("topic") or entry.get("name") or "").strip()
        if not topic:
            spec.note(entry.where(), "a whitelist entry without `topic:` is skipped")
            continue
        target = spec.topic_paths.get(topic) or quote(topic)
        lines = [f"whitelist {target} {{"]
        for keyword in ("publishers", "subscribers"):
            line = _pattern_line(keyword, _patterns(entry.get(keyword)))
            if line:
                lines.append(line)
        if len(lines) == 1:
            spec.note(
                entry.where(),
                f"whitelist of `{topic}` has neither publishers nor subscribers: skipped",
            )
            continue
        lines.append("}")
        spec.add(spec.whitelists, "\n".join(lines), entry.where(), f"the whitelist of `{topic}`")


def _nodes(entries: list[Located], spec: _Spec) -> None:
    for entry in entries:
        node = str(entry.get("node") or entry.get("name") or "").strip()
        if not node:
            spec.note(entry.where(), "a node entry without `node:` is skipped")
            continue
        lines = [f"node {quote(node)} {{"]
        for keyword in ("publishes", "subscribes"):
            line = _pattern_line(keyword, _patterns(entry.get(keyword)))
            if line:
                lines.append(line)
        lines.append("}")
        spec.add(spec.whitelists, "\n".join(lines), entry.where(), f"the rules of node `{node}`")
