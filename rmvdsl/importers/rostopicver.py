"""rostopicver's and rostopicintrusion's configurations (thesis 3.5, 3.6) into .rmv:
transducers, RMTLD3 monitors as properties, topic whitelists and node rules."""

from __future__ import annotations

import os
from typing import Any

from rmvdsl.grammar.printer import quote
from rmvdsl.importers.draft import Draft, claim, entries, identifier, scalars
from rmvdsl.importers.located import Located
from rmvdsl.importers.rostopicmon import (
    _NOW_RANGE,
    _NUMBER,
)


def convert_transducer(path: str, document: Located, spec: Draft) -> None:
    name = claim(
        spec,
        identifier(os.path.splitext(os.path.basename(path))[0].title().replace("_", ""), "States"),
        document.where("states"),
    )
    states = [
        identifier(s, "state") for s in scalars(document.get("states"), spec, document, "states")
    ]
    initials = scalars(document.get("initial"), spec, document, "initial")
    initial = initials[0] if initials else None
    lines = [f"transducer {name} {{"]
    if states:
        lines.append("    states " + ", ".join(states))
    if initial is not None:
        lines.append(f"    initial {identifier(str(initial), 'state')}")
    for entry in entries(document.get("transitions"), spec, document, "transitions"):
        source, dest = entry.get("source"), entry.get("dest")
        event = entry.get("inputtapeEvent")
        if not (source and dest and event):
            spec.note(
                entry.where(), "a transition needs `source`, `dest` and `inputtapeEvent`: skipped"
            )
            continue
        source_state, dest_state = identifier(str(source), "s"), identifier(str(dest), "s")
        text = f"    {source_state} -> {dest_state} on {identifier(str(event), 'e')}"
        output = entry.get("outputtapeEvent")
        if output:
            text += f" emit {identifier(str(output), 'e')}"
        lines.append(text)
    lines.append("}")
    if spec.add(spec.transducers, "\n".join(lines), document.where("states"), "the transducer"):
        spec.names.update(states)


def convert_rmtld3_monitor(monitor: Located, spec: Draft) -> None:
    name = claim(
        spec,
        identifier(str(monitor.get("monitor_name") or "property"), "property"),
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
        members.append(f"    trigger = {identifier(trigger, 'always')}")
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


def _patterns(value: Any) -> list[str] | None:
    if value is None:
        return None
    items = value if isinstance(value, list) else [value]
    return [str(v).strip() for v in items if v is not None and str(v).strip()]


def _pattern_line(keyword: str, patterns: list[str] | None) -> str | None:
    if patterns is None:
        return None
    return f"    {keyword}: " + (", ".join(quote(p) for p in patterns) if patterns else "none")


def convert_whitelists(entries: list[Located], spec: Draft) -> None:
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


def convert_nodes(entries: list[Located], spec: Draft) -> None:
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
