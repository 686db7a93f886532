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
from rmvdsl.check.edit import EditCheck, check_edit, prepare_edits
from rmvdsl.check.model import Kind, Model, Symbol
from rmvdsl.editor.mentions import Mention
from rmvdsl.lang.files import read_text
from rmvdsl.lang.source import SourceFile, Span
from rmvdsl.util.deep import deep

__all__ = [
    "TOKEN_TYPES",
    "CheckResult",
    "Found",
    "Token",
    "Workspace",
    "details",
    "folds",
    "formatted",
    "references",
    "rename",
    "semantic_tokens",
    "symbol_at",
    "warm_up",
]  # fmt: skip


def _key(path: str) -> str:
    return os.path.normcase(os.path.realpath(path))


class Workspace:
    """Open documents by path; reads prefer them to the disk, imports included.

    An `incremental` workspace (the editor's) checks again only the declarations an
    edit changed or could affect (rmvdsl.check.memo); the answers are the same."""

    def __init__(self, incremental: bool = False) -> None:
        self.incremental = incremental
        self._open: dict[str, str] = {}
        self._lock = threading.Lock()

    def open(self, path: str, text: str) -> None:
        with self._lock:
            self._open[_key(path)] = text

    def close(self, path: str) -> None:
        with self._lock:
            self._open.pop(_key(path), None)

    def documents(self) -> dict[str, str]:
        """Every open document's text, by path."""
        with self._lock:
            return dict(self._open)

    def show(self, documents: dict[str, str]) -> None:
        """Exactly these documents open (another Workspace's `documents()`)."""
        with self._lock:
            self._open = {_key(path): text for path, text in documents.items()}

    def text(self, path: str) -> str | None:
        with self._lock:
            return self._open.get(_key(path))

    def read(self, path: str) -> str:
        """A file's text: the open document's, else the disk's."""
        text = self.text(path)
        return read_text(path) if text is None else text

    def check(self, path: str, solver: bool = True, **options: Any) -> CheckResult:
        """`rmv check` of `path` as the open documents say it is now."""
        options.setdefault("incremental", self.incremental)
        result = check(path, self.text(path), read=self.read, solver=solver, **options)
        if self.incremental:
            prepare_edits(result)  # beside the check, not at the next keystroke
        return result

    def check_edit(self, path: str, text: str, before: CheckResult) -> EditCheck | None:
        """The fast stages' diagnostics of `text`, the document's new text, from
        `before` when the edit stays inside a few declarations (rmvdsl.check.edit).
        On a deep stack, as every check (rmvdsl.util.deep): a check running beside
        it has raised the interpreter's recursion limit for its own."""
        return deep(check_edit, before, path, text)


def warm_up() -> None:
    """Build what requests build on first use: the grammar's tables that completion
    (and the recovery from a syntax error) replay tokens on, and the movers of the
    syntax tree's classes a keystroke moves (rmvdsl.grammar.shift). An editor
    calls it once its first text is checked, so no keystroke pays for it."""
    from rmvdsl.grammar import ast, formula
    from rmvdsl.grammar.grammars import recognizer
    from rmvdsl.grammar.shift import write_movers
    from rmvdsl.lang import diagnostics

    recognizer()
    for module in (ast, formula, diagnostics):
        write_movers(module)


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


# ---- rename and quick fixes ----

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def rename(model: Model, symbol: Symbol, new: str) -> list[Span]:
    """The spans to rewrite to rename `symbol` to `new`; ValueError says why not."""
    if not _IDENTIFIER.fullmatch(new):
        raise ValueError(f"`{new}` is not a name: a letter or `_`, then letters, digits, `_`")
    from rmvdsl.grammar.grammars import keywords

    if new in keywords():
        raise ValueError(f"`{new}` is a keyword of the language")
    if new != symbol.name and new in model.symbols:
        other = model.symbols[new]
        raise ValueError(f"`{new}` is already {other.kind.described()}")
    return references(model, symbol, declaration=True)


# ---- hover ----


def details(result: CheckResult, symbol: Symbol) -> list[str]:
    """What a check knows of a symbol, as Markdown lines: a variable's kind, ROS type
    and unit; a topic's message type and its fields; an event's type; a property's
    horizon and what the analyses found."""
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
        back = "to the start" if horizon.past is None else f"{float(horizon.past):g} s"
        lines.append(f"horizon: {float(horizon.future):g} s ahead, {back} back")
    facts = result.properties.facts.get(name) if result.properties is not None else None
    if facts is not None:
        for what, answer in (("can hold", facts.satisfiable), ("always holds", facts.valid)):
            if answer is not None:
                lines.append(f"{what}: {answer.value}{'' if answer.exact else ' (bounded)'}")
    return lines


# ---- semantic tokens ----

TOKEN_TYPES = (
    "interface", "variable", "event", "macro", "class", "enumMember", "function", "property",
    "type", "namespace", "string",
)  # fmt: skip
_TOKEN_OF_KIND = {
    "topic": "interface", "variable": "variable", "event": "event", "boolean event": "event",
    "emitted event": "event", "alert": "macro", "transducer": "class", "state": "enumMember",
    "property": "function",
}  # fmt: skip
_TOKEN_OF_MENTION = {"field": "property", "message": "type", "retention": "namespace",
                     "import": "string"}  # fmt: skip


@dataclass(frozen=True)
class Token:
    span: Span
    type: str  # one of TOKEN_TYPES
    declaration: bool


def semantic_tokens(result: CheckResult, path: str, found: list[Mention]) -> list[Token]:
    """What each name of `path` is (its declaration marked), field-path segments,
    message types and retention policies, in file order; keywords, numbers and
    comments are the TextMate grammar's."""
    model = result.model
    tokens = [Token(s.span, _TOKEN_OF_KIND[s.kind.value], True)
              for s in model.symbols.values() if s.span.path == path]  # fmt: skip
    tokens += [Token(r.span, _TOKEN_OF_KIND[r.symbol.kind.value], False)
               for r in model.references if r.span.path == path]  # fmt: skip
    tokens += [Token(m.span, _TOKEN_OF_MENTION[m.kind], m.declares)
               for m in found if m.span.path == path and m.kind != "import"]  # fmt: skip
    tokens.sort(key=lambda t: (t.span.start, t.span.end))
    out: list[Token] = []
    for token in tokens:  # one token per place (a name is declared once)
        if not out or token.span.start >= out[-1].span.end:
            out.append(token)
    return out


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
