"""The .rmv text an import is writing: its declarations by kind, the names taken, and
the notes on what was not carried over; and the helpers every converter shares."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

from rmvdsl.grammar.parser import parse_source
from rmvdsl.importers.located import Located
from rmvdsl.lang.source import SourceFile
from rmvdsl.runtime.wording import visible


@dataclass
class Draft:
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
        if parses(text):
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


def entries(value: Any, spec: Draft, parent: Located, key: str) -> list[Located]:
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
                f"an entry of `{key}` is not a mapping: `{short(item)}` skipped",
            )
    return entries


def scalars(value: Any, spec: Draft, parent: Located, key: str) -> list[str]:
    """A list of plain values (`states: [A, B]`); anything else is noted."""
    if value is None:
        return []
    if not isinstance(value, list):
        spec.note(parent.where(key), f"`{key}` should be a list, not `{short(value)}`")
    items = value if isinstance(value, list) else [value]
    out = []
    for item in items:
        if isinstance(item, str | int | float) and not isinstance(item, bool):
            out.append(str(item))
        elif item is not None:
            spec.note(parent.where(key), f"`{key}` holds `{short(item)}`, not a name: skipped")
    return out


def short(value: Any) -> str:
    text = " ".join(repr(value).split())
    return text if len(text) <= 40 else text[:37] + "..."


def identifier(text: str, fallback: str) -> str:
    cleaned = re.sub(r"[^A-Za-z0-9_]", "_", text.strip())
    if not cleaned:
        return fallback
    return cleaned if not cleaned[0].isdigit() else "_" + cleaned


def claim(spec: Draft, wanted: str, where: str) -> str:
    name = wanted
    counter = 2
    while name in spec.names:
        name = f"{wanted}_{counter}"
        counter += 1
    if name != wanted:
        spec.note(where, f"`{wanted}` is used twice: the second is renamed `{name}`")
    spec.names.add(name)
    return name


def parses(declaration: str) -> bool:
    parsed = parse_source(SourceFile("<check>", declaration))
    return not any(d.is_error for d in parsed.diagnostics) and len(parsed.spec.items) == 1
