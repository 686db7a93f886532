"""The front end an editor drives: documents open in it (their unsaved text) over the
files on disk, checked in two steps, and what stands at a position.

`rmv check` and `rmv lsp` both check through a Workspace, so the two never disagree:
the command line's has no open documents. The fast stages (loading, names, types)
answer at once; the solver stages (transducer and property analyses) run after them
and may be abandoned when the text changes again (the editor's `generation`).
"""

from __future__ import annotations

import os
import re
import threading
from dataclasses import dataclass
from typing import Any

from rmvdsl.check import CheckResult, check
from rmvdsl.check.loader import read_text
from rmvdsl.check.model import Model, Symbol
from rmvdsl.source import SourceFile, Span

__all__ = [
    "CheckResult", "Completion", "Found", "Workspace", "completions", "details", "folds",
    "formatted", "quick_fix", "references", "rename", "symbol_at",
]  # fmt: skip


def _key(path: str) -> str:
    return os.path.normcase(os.path.realpath(path))


class Workspace:
    """Open documents by path; reads prefer them to the disk, imports included."""

    def __init__(self) -> None:
        self._open: dict[str, str] = {}
        self._lock = threading.Lock()

    def open(self, path: str, text: str) -> None:
        with self._lock:
            self._open[_key(path)] = text

    def close(self, path: str) -> None:
        with self._lock:
            self._open.pop(_key(path), None)

    def text(self, path: str) -> str | None:
        with self._lock:
            return self._open.get(_key(path))

    def read(self, path: str) -> str:
        """A file's text: the open document's, else the disk's."""
        text = self.text(path)
        return read_text(path) if text is None else text

    def check(self, path: str, solver: bool = True, **options: Any) -> CheckResult:
        """`rmv check` of `path` as the open documents say it is now."""
        return check(path, self.text(path), read=self.read, solver=solver, **options)


@dataclass(frozen=True)
class Found:
    """What stands at a position: a declared name or a use of one."""

    symbol: Symbol
    span: Span  # the name under the cursor


def symbol_at(model: Model, path: str, offset: int) -> Found | None:
    """The symbol whose declaration or use covers `offset` in `path`."""
    for symbol in model.symbols.values():
        span = symbol.span
        if span.path == path and span.start <= offset <= span.end:
            return Found(symbol, span)
    for reference in model.references:
        span = reference.span
        if span.path == path and span.start <= offset <= span.end:
            return Found(reference.symbol, span)
    return None


def references(model: Model, symbol: Symbol, declaration: bool = True) -> list[Span]:
    """Every span naming `symbol`: its declaration (if asked) and its uses."""
    spans = [r.span for r in model.uses_of(symbol)]
    return [symbol.span, *spans] if declaration else spans


def formatted(path: str, text: str) -> str | None:
    """`rmv fmt` of a text, or None when it has syntax errors (nothing to format)."""
    from rmvdsl.grammar.formatter import format_source

    return format_source(SourceFile(path, text))[0]


# ---- completion ----

DECLARATIONS = (
    "system", "import", "time unit", "ros", "messages", "database", "topic", "var", "event",
    "transducer", "property", "alert", "whitelist", "node", "intrusion",
)  # fmt: skip
CLAUSES = ("when", "where", "group by time", "fill", "order", "limit", "resample every", "range",
           "and", "or", "not", "always", "eventually", "until", "since", "historically", "once",
           "duration", "action", "emit", "on")  # fmt: skip
_OPENER = re.compile(r"^\s*(\w+)")
_SETTING_VALUE = re.compile(r"^\s*(\w+)\s*=\s*\w*$")


@dataclass(frozen=True)
class Completion:
    label: str
    kind: str  # keyword | function | setting | value | a name's kind (topic, variable, ...)
    detail: str = ""
    doc: str = ""


def _enclosing_block(before: str) -> str | None:
    """The kind of block the cursor is in (`database`, `qos`, `property`, ...):
    the word that opens the line of the innermost unclosed `{`."""
    depth = 0
    for index in range(len(before) - 1, -1, -1):
        char = before[index]
        if char == "}":
            depth += 1
        elif char == "{":
            if depth == 0:
                line = before[before.rfind("\n", 0, index) + 1 : index]
                if re.search(r"\bqos\s*$", line):
                    return "qos"
                opener = _OPENER.match(line)
                return opener.group(1) if opener else None
            depth -= 1
    return None


def completions(model: Model | None, text: str, offset: int) -> list[Completion]:
    """What may be written at `offset`: a setting's values after `key =` inside a
    block, the block's settings at the start of a line in it, the declarations at
    the start of a line outside blocks, else the names in scope (by kind), the
    functions of the registry and the clause and formula keywords."""
    from rmvdsl import builtins

    before = text[:offset]
    line = before[before.rfind("\n") + 1 :]
    block = _enclosing_block(before)
    settings = builtins.BLOCKS.get(block) if block else None
    at_start = re.fullmatch(r"\s*\w*", line) is not None
    if settings is not None:
        value = _SETTING_VALUE.match(line)
        if value and value.group(1) in settings.settings:
            spec = settings.settings[value.group(1)]
            return [Completion(c, "value", spec.doc) for c in spec.choices]
        if at_start:
            return [Completion(s.key, "setting", f"default {s.shown}", s.doc)
                    for s in settings.settings.values()]  # fmt: skip
    if block is None and at_start:
        return [Completion(word, "keyword", "declaration") for word in DECLARATIONS]
    found = [Completion(w, "keyword", "clause") for w in CLAUSES]
    found += [Completion(f.name, "function", f.group, f.doc) for f in builtins.FUNCTIONS.values()]
    if model is not None:
        found += [Completion(s.name, s.kind.value, s.kind.described())
                  for s in model.symbols.values()]  # fmt: skip
    return found


# ---- rename and quick fixes ----

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_DID_YOU_MEAN = re.compile(r"did you mean `([^`]+)`\?")


def rename(model: Model, symbol: Symbol, new: str) -> list[Span]:
    """The spans to rewrite to rename `symbol` to `new`; ValueError says why not."""
    if not _IDENTIFIER.fullmatch(new):
        raise ValueError(f"`{new}` is not a name: a letter or `_`, then letters, digits, `_`")
    from rmvdsl.grammar.parser import keywords

    if new in keywords():
        raise ValueError(f"`{new}` is a keyword of the language")
    if new != symbol.name and new in model.symbols:
        other = model.symbols[new]
        raise ValueError(f"`{new}` is already {other.kind.described()}")
    return references(model, symbol, declaration=True)


def quick_fix(message: str | None) -> str | None:
    """The replacement a diagnostic's help proposes (`did you mean `X`?`)."""
    found = _DID_YOU_MEAN.search(message or "")
    return found.group(1) if found else None


# ---- hover ----


def details(result: CheckResult, symbol: Symbol) -> list[str]:
    """What a check knows of a symbol, as Markdown lines: a variable's kind, ROS type
    and unit; a topic's message type and its fields; an event's type; a property's
    horizon and what the analyses found."""
    from rmvdsl.check.model import Kind

    types, name = result.types, symbol.name
    lines: list[str] = []
    if types is not None and symbol.kind is Kind.VARIABLE and name in types.variables:
        lines.append(_value_type(types.variables[name]))
    elif types is not None and symbol.kind is Kind.TOPIC and types.topics.get(name):
        message = types.topics[name]
        assert message is not None
        fields = ", ".join(f"`{f}: {t.base}{'[]' if t.array else ''}`"
                           for f, t in list(message.fields.items())[:12])  # fmt: skip
        lines.append(f"message `{message.name}` ({message.origin}): {fields}")
    elif types is not None and symbol.kind.value.endswith("event") and name in types.events:
        lines.append(_value_type(types.events[name]))
    elif symbol.kind is Kind.PROPERTY:
        lines.extend(_property_lines(result, name))
    return lines


def _value_type(vtype: Any) -> str:
    unit = {-1: " per second", 1: " times seconds"}.get(vtype.rate, "")
    ros = f" (ROS `{vtype.ros}`)" if vtype.ros else ""
    return f"type: {vtype.kind}{unit}{ros}"


def _property_lines(result: CheckResult, name: str) -> list[str]:
    lines = []
    if result.types is not None and name in result.types.horizons:
        horizon = result.types.horizons[name]
        lines.append(f"horizon: {float(horizon.future):g} s ahead, {float(horizon.past):g} s back")
    facts = result.properties.facts.get(name) if result.properties is not None else None
    if facts is not None:
        for what, answer in (("can hold", facts.satisfiable), ("always holds", facts.valid)):
            if answer is not None:
                lines.append(f"{what}: {answer.value}{'' if answer.exact else ' (bounded)'}")
    return lines


def folds(model: Model, path: str) -> list[tuple[int, int]]:
    """The 0-based first and last lines of each declaration of `path` that spans
    more than one line (an editor folds them)."""
    source = model.sources.get(path)
    spec = next((s for s in model.specs if s.path == path), None)
    if source is None or spec is None:
        return []
    out = []
    for item in spec.items:
        first = source.position(item.span.start).line - 1
        last = source.position(max(item.span.start, item.span.end - 1)).line - 1
        if last > first:
            out.append((first, last))
    return out
