"""Completion: what may be written at a position of a spec, from the most
specific context out (a setting's values, message types, a message's fields, what
the grammar accepts there and the names in scope), and what of it an editor is
sent (rmvdsl.editor.ranking)."""

from __future__ import annotations

import bisect
import re
import weakref
from itertools import compress
from operator import attrgetter
from typing import NamedTuple

from rmvdsl.check import CheckResult
from rmvdsl.check.model import (
    BOOLEAN_KINDS,
    EVENT_KINDS,
    PROPOSITION_KINDS,
    Kind,
    Model,
    Symbol,
)
from rmvdsl.editor.ranking import LIMIT, Labels, joined, labels_of, shortlist, typed_word

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
    return [*found, *map(_named, names.symbols)]


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
    items: list[Completion | Symbol] = [*found, *names.symbols]
    labels = joined(labels_of([c.label for c in found]), names.labels)
    sent, cut = shortlist(items, labels, typed_word(text, offset), limit)
    return [c if isinstance(c, Completion) else _named(c) for c in sent], cut


def _named(symbol: Symbol) -> Completion:
    return Completion(symbol.name, symbol.kind.value, symbol.kind.described())


class _Names(NamedTuple):
    """The names in scope in a kind of declaration, and their labels."""

    symbols: list[Symbol]
    labels: Labels


_NO_NAMES = _Names([], labels_of([]))


def _candidates(
    result: CheckResult | None, text: str, offset: int, path: str | None
) -> tuple[list[Completion], _Names]:
    """`completions`: the names in scope apart (each made a Completion by
    `_named`), the rest made."""
    from rmvdsl.grammar.parser import chunk_start
    from rmvdsl.grammar.scanner import scan

    start = offset - len(typed_word(text, offset))
    # The declaration the cursor is in (blocks never span two). A chunk starting
    # at `start` is the word being completed: what came before decides, as a scan
    # of the text before it says.
    if path is not None:
        chunk = chunk_start(path, text, start)
    else:
        chunks = scan(text[:start]).chunks
        before = bisect.bisect_left(chunks, (start,))  # chunks are (start, line)
        chunk = chunks[before - 1][0] if before else 0
    line_start = text.rfind("\n", 0, start) + 1
    line = text[line_start:start]
    settings = _block_settings(text[chunk:start], line)
    if settings is not None:
        return settings, _NO_NAMES
    if _MESSAGE_TYPE.match(text[line_start:offset]):
        return _message_types(result), _NO_NAMES
    field_path = _FIELD_PATH.search(line)
    if field_path is not None and result is not None and field_path.group(1) in result.model.topics:
        return _fields(result, field_path.group(1), field_path.group(2)), _NO_NAMES
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
) -> tuple[list[Completion], _Names]:
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
        return found, _NO_NAMES
    opener = _OPENER.match(text[chunk:start])
    if opener is not None and opener.group(1) in _WITH_FUNCTIONS:
        found += [Completion(f.name, "function", f.group, f.doc)
                  for f in builtins.FUNCTIONS.values()]  # fmt: skip
    if result is None:
        return found, _NO_NAMES
    return found, _names_in(result.model, _NAMES_IN.get(opener.group(1) if opener else ""))


# The names of the model completed in last, by the kinds asked for (None: all):
# worked out once per check, not at each key; dropped with the model.
_KEPT: list[tuple[weakref.ref[Model], dict[frozenset[Kind] | None, _Names]]] = []


def _names_in(model: Model, kinds: frozenset[Kind] | None) -> _Names:
    """The model's names of those kinds (None: of any), in declaration order."""
    if not _KEPT or _KEPT[0][0]() is not model:
        _KEPT[:] = [(weakref.ref(model, _forget), {})]
    kept = _KEPT[0][1]
    names = kept.get(kinds)
    if names is None:
        symbols = list(model.symbols.values())
        if kinds is not None:
            of_kind = map(kinds.__contains__, map(attrgetter("kind"), symbols))
            symbols = list(compress(symbols, of_kind))
        names = kept[kinds] = _Names(symbols, labels_of(list(map(attrgetter("name"), symbols))))
    return names


def _forget(gone: weakref.ref[Model]) -> None:
    if _KEPT and _KEPT[0][0] is gone:
        _KEPT.clear()


# The kinds of names that may stand in each declaration (the names stage's rules).
_NAMES_IN: dict[str, frozenset[Kind]] = {
    "var": frozenset({Kind.TOPIC}),
    "event": frozenset({Kind.VARIABLE, *EVENT_KINDS}),
    "alert": frozenset({Kind.VARIABLE, *EVENT_KINDS}),
    "transducer": frozenset({Kind.STATE, *BOOLEAN_KINDS}),
    "property": PROPOSITION_KINDS,
    "whitelist": frozenset({Kind.TOPIC}),
}
