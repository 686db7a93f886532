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
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from rmvdsl.grammar.formatter import format_spec
from rmvdsl.grammar.parser import parse_source
from rmvdsl.importers.draft import Draft, entries, identifier
from rmvdsl.importers.located import Located, load_yaml
from rmvdsl.importers.rostopicmon import (
    convert_database,
    convert_events,
    convert_kapacitor_monitor,
    convert_topics,
    convert_variables,
)
from rmvdsl.importers.rostopicver import (
    convert_nodes,
    convert_rmtld3_monitor,
    convert_transducer,
    convert_whitelists,
)
from rmvdsl.lang.errors import UsageError
from rmvdsl.lang.source import SourceFile


@dataclass
class ImportResult:
    text: str
    notes: list[str] = field(default_factory=list)


def convert_files(paths: Iterable[str], system_name: str | None = None) -> ImportResult:
    spec = Draft()
    documents = [(path, load_yaml(path)) for path in paths]
    name = system_name or identifier(
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
            raise UsageError(f"{path}: expected a YAML mapping at the top (`topics:` ...), "
                             f"found {_yaml_kind(document)}")  # fmt: skip
        _convert_document(path, document, spec)
    text = _canonical(spec.text(), spec)
    _report_open_names(text, spec)
    return ImportResult(text, spec.notes)


def _report_open_names(text: str, spec: Draft) -> None:
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


def _canonical(text: str, spec: Draft) -> str:
    source = SourceFile("<import>", text)
    parsed = parse_source(source)
    errors = [d for d in parsed.diagnostics if d.is_error]
    if errors:
        for diagnostic in errors:
            line = source.position(diagnostic.span.start).line
            spec.note("<output>", f"line {line}: {diagnostic.message} (left as written)")
        return text
    return format_spec(parsed.spec, source)


def _convert_document(path: str, document: Located, spec: Draft) -> None:
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
        convert_database(document, spec)
    topics = entries(document.get("topics"), spec, document, "topics")
    if _is_intrusion_list(topics):
        convert_whitelists(topics, spec)
    else:
        convert_topics(topics, spec)
    for key in ("whitelist", "whitelists"):
        convert_whitelists(entries(document.get(key), spec, document, key), spec)
    convert_nodes(entries(document.get("nodes"), spec, document, "nodes"), spec)
    convert_variables(entries(document.get("variables"), spec, document, "variables"), spec)
    convert_events(entries(document.get("events"), spec, document, "events"), spec)
    if "states" in document or "transitions" in document:
        convert_transducer(path, document, spec)
    for monitor in entries(document.get("monitors"), spec, document, "monitors"):
        generator = str(monitor.get("monitor_gen", "")).strip()
        if generator == "kapacitor":
            convert_kapacitor_monitor(path, monitor, spec)
        elif generator in ("rmtld3synth", "rtmld3synth"):
            convert_rmtld3_monitor(monitor, spec)
        else:
            spec.note(
                monitor.where("monitor_gen"),
                f"monitor generator `{generator}` is unknown; "
                "expected `kapacitor` or `rmtld3synth`: monitor not carried over",
            )


def _is_intrusion_list(topics: Any) -> bool:
    return isinstance(topics, list) and any(
        isinstance(t, dict) and ("publishers" in t or "subscribers" in t) for t in topics
    )


def _yaml_kind(document: object) -> str:
    """What a YAML document is, in YAML's words."""
    if document is None:
        return "nothing (the file is empty)"
    if isinstance(document, bool):
        return "true or false"
    if isinstance(document, int | float):
        return "a number"
    if isinstance(document, str):
        return "a string"
    if isinstance(document, list):
        return "a list"
    return "something else"
