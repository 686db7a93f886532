"""The front end an editor drives: documents open in it (their unsaved text) over the
files on disk, checked in two steps, and what stands at a position.

`rmv check` and `rmv lsp` both check through a Workspace, so the two never disagree:
the command line's has no open documents. The fast stages (loading, names, types)
answer at once; the solver stages (transducer and property analyses) run after them
and may be abandoned when the text changes again (the editor's `generation`).
"""

from __future__ import annotations

import bisect
import os
import re
import threading
from dataclasses import dataclass
from itertools import compress
from operator import attrgetter
from typing import Any, NamedTuple

from rmvdsl.check import CheckResult, check
from rmvdsl.check.loader import read_text
from rmvdsl.check.model import BOOLEAN_KINDS, EVENT_KINDS, PROPOSITION_KINDS, Kind, Model, Symbol
from rmvdsl.editor.mentions import Mention
from rmvdsl.editor.ranking import LIMIT, shortlist, typed_word
from rmvdsl.lang.source import SourceFile, Span

__all__ = [
    "TOKEN_TYPES",
    "CheckResult",
    "Completion",
    "Found",
    "Token",
    "Workspace",
    "completions",
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
        return check(path, self.text(path), read=self.read, solver=solver, **options)


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


# ---- completion ----

_OPENER = re.compile(r"^\s*(\w+)")
_SETTING_VALUE = re.compile(r"^\s*(\w+)\s*=\s*$")
_MESSAGE_TYPE = re.compile(r"^\s*topic\s+\w+\s*:\s*[\w/]*$")
_FIELD_PATH = re.compile(r"\b([A-Za-z_]\w*)((?:\.[A-Za-z_]\w*(?:\[[^\]\n]*\])?)*)\.$")
_SEGMENT = re.compile(r"\.([A-Za-z_]\w*)(\[[^\]\n]*\])?")
# Where InfluxQL's functions may be called.
_WITH_FUNCTIONS = frozenset({"event", "alert", "var"})


class Completion(NamedTuple):
    """What may be written at a position. A tuple: `completions` makes one per
    name in scope, and a frozen dataclass's `__init__` (a `setattr` per field)
    took most of its time in a spec of 10,000 names."""

    label: str
    kind: str  # keyword | function | setting | value | message | field | a name's kind
    detail: str = ""
    doc: str = ""


def _enclosing_block(before: str) -> str | None:
    """The kind of block the cursor is in (`database`, `qos`, `property`, ...):
    the word that opens the line of the innermost unclosed `{` (`before`: the
    declaration up to the cursor). It jumps from brace to brace."""
    depth = 0
    index = len(before)
    while True:
        index = max(before.rfind("{", 0, index), before.rfind("}", 0, index))
        if index < 0:
            return None
        if before[index] == "}":
            depth += 1
            continue
        if depth == 0:
            line = before[before.rfind("\n", 0, index) + 1 : index]
            if re.search(r"\bqos\s*$", line):
                return "qos"
            opener = _OPENER.match(line)
            return opener.group(1) if opener else None
        depth -= 1


def completions(
    result: CheckResult | None, text: str, offset: int, path: str | None = None
) -> list[Completion]:
    """What may be written at `offset`, from the most specific context out: a
    setting's values after `key =` and the settings of the block at a line's start;
    message types after `topic Name:`; a message's fields after `topic.` segment by
    segment; else what the grammar accepts there (its keywords and, where a name
    may stand, the names in scope and InfluxQL's functions). `path`: the file the
    text is of, whose last scan is then reused (an editor's)."""
    found, names = _candidates(result, text, offset, path)
    return [*found, *map(_named, names)]


def sent_completions(
    result: CheckResult | None,
    text: str,
    offset: int,
    path: str | None = None,
    limit: int = LIMIT,
) -> tuple[list[Completion], bool]:
    """`completions` as an editor is sent them (rmvdsl.editor.ranking.shortlist),
    and whether the list was cut: a name's completion is made only if it is sent
    (in a spec of 10,000 names, making one for each took most of a request)."""
    found, names = _candidates(result, text, offset, path)
    items: list[Completion | Symbol] = [*found, *names]
    labels = [c.label for c in found] + list(map(attrgetter("name"), names))
    sent, cut = shortlist(items, labels, typed_word(text, offset), limit)
    return [c if isinstance(c, Completion) else _named(c) for c in sent], cut


def _named(symbol: Symbol) -> Completion:
    return Completion(symbol.name, symbol.kind.value, symbol.kind.described())


def _candidates(
    result: CheckResult | None, text: str, offset: int, path: str | None
) -> tuple[list[Completion], list[Symbol]]:
    """`completions`: the names in scope apart (each made a Completion by
    `_named`), the rest made."""
    from rmvdsl.grammar.parser import scan_file
    from rmvdsl.grammar.scanner import scan

    start = offset - len(typed_word(text, offset))
    scanned = scan_file(path, text) if path is not None else scan(text[:start])
    # The declaration the cursor is in (blocks never span two). A chunk starting
    # at `start` is the word being completed: what came before decides, as a scan
    # of the text before it says.
    before = bisect.bisect_left(scanned.chunks, (start,))  # chunks are (start, line)
    chunk = scanned.chunks[before - 1][0] if before else 0
    line_start = text.rfind("\n", 0, start) + 1
    line = text[line_start:start]
    settings = _block_settings(text[chunk:start], line)
    if settings is not None:
        return settings, []
    if _MESSAGE_TYPE.match(text[line_start:offset]):
        return _message_types(result), []
    field_path = _FIELD_PATH.search(line)
    if field_path is not None and result is not None and field_path.group(1) in result.model.topics:
        return _fields(result, field_path.group(1), field_path.group(2)), []
    return _grammar_completions(result, text, chunk, start)


def _block_settings(declaration: str, line: str) -> list[Completion] | None:
    from rmvdsl.lang import builtins

    block = _enclosing_block(declaration)
    settings = builtins.BLOCKS.get(block) if block else None
    if settings is None:
        return None
    value = _SETTING_VALUE.match(line)
    if value and value.group(1) in settings.settings:
        spec = settings.settings[value.group(1)]
        return [Completion(c, "value", spec.doc) for c in spec.choices]
    if not line.strip():
        return [Completion(s.key, "setting", f"default {s.shown}", s.doc)
                for s in settings.settings.values()]  # fmt: skip
    return None


def _message_types(result: CheckResult | None) -> list[Completion]:
    if result is None or result.types is None:
        return []
    registry = result.types.registry
    out = []
    for name in sorted(set(registry.names())):
        definition = registry.get(name)
        origin = definition.origin if definition is not None else ""
        package, _, type_name = name.partition("/msg/")
        out.append(Completion(f"{package}/{type_name}" if type_name else name, "message", origin))
    return out


def _fields(result: CheckResult, topic: str, path: str) -> list[Completion]:
    """The fields (and constants) of the message reached by `path` from the topic."""
    if result.types is None:
        return []
    registry = result.types.registry
    message = result.types.topics.get(topic)
    for segment in _SEGMENT.finditer(path):
        if message is None:
            return []
        step = message.fields.get(segment.group(1))
        message = registry.get(step.base) if step is not None else None
    if message is None:
        return []
    found = [Completion(f, "field", k.text(), message.name) for f, k in message.fields.items()]
    found += [Completion(c, "constant", f"{kind} = {value}", message.name)
              for c, (kind, value) in message.constants.items()]  # fmt: skip
    return found


def _grammar_completions(
    result: CheckResult | None, text: str, chunk: int, start: int
) -> tuple[list[Completion], list[Symbol]]:
    from rmvdsl.grammar.grammars import accepted_words
    from rmvdsl.grammar.scanner import TOP_LEVEL_KEYWORDS
    from rmvdsl.lang import builtins

    accepted = accepted_words(text, chunk, start)
    words, names = accepted if accepted is not None else (frozenset(), True)
    line = text[text.rfind("\n", 0, start) + 1 : start]
    if not line and _enclosing_block(text[chunk:start]) is None:
        # A line's first word outside blocks starts a new declaration (the scanner's
        # rule), whatever the declaration before it lacks.
        words |= TOP_LEVEL_KEYWORDS
    found = [Completion(w, "keyword", "keyword") for w in sorted(words)]
    if not names:
        return found, []
    opener = _OPENER.match(text[chunk:start])
    if opener is not None and opener.group(1) in _WITH_FUNCTIONS:
        found += [Completion(f.name, "function", f.group, f.doc)
                  for f in builtins.FUNCTIONS.values()]  # fmt: skip
    if result is None:
        return found, []
    kinds = _NAMES_IN.get(opener.group(1) if opener else "")
    symbols = list(result.model.symbols.values())
    if kinds is None:
        return found, symbols
    return found, list(compress(symbols, map(kinds.__contains__, map(attrgetter("kind"), symbols))))


# The kinds of names that may stand in each declaration (the names stage's rules).
_NAMES_IN: dict[str, frozenset[Kind]] = {
    "var": frozenset({Kind.TOPIC}),
    "event": frozenset({Kind.VARIABLE, *EVENT_KINDS}),
    "alert": frozenset({Kind.VARIABLE, *EVENT_KINDS}),
    "transducer": frozenset({Kind.STATE, *BOOLEAN_KINDS}),
    "property": PROPOSITION_KINDS,
    "whitelist": frozenset({Kind.TOPIC}),
}


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
