"""Declarations checked alone, against the model and the types of a check of the
whole spec: their own findings (their chunks' parse, their names, their types)
and what the other declarations see of them (rmvdsl.check.edit compares the old
and the new declarations of an edit). Checked on copies: the model and the types are left as
they were, for the editor reads them meanwhile."""

from __future__ import annotations

import bisect
import dataclasses
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, cast

from rmvdsl.check import CONSEQUENTIAL
from rmvdsl.check.model import Kind, Model, Reference, Symbol
from rmvdsl.check.names import NameChecker, Resolved
from rmvdsl.check.readers import use_counts
from rmvdsl.check.typeinfo import TypeInfo
from rmvdsl.check.types import TypeChecker, TypeConfig
from rmvdsl.grammar import ast
from rmvdsl.grammar.shift import findings
from rmvdsl.lang.diagnostics import Diagnostic, may_sway
from rmvdsl.lang.source import SourceMap, Span

# The model's map of each of them, by name.
_GROUPS: dict[type, str] = {
    ast.VarDecl: "variables",
    ast.EventDecl: "events",
    ast.AlertDecl: "alerts",
    ast.PropertyDecl: "properties",
    ast.TransducerDecl: "transducers",
}


@dataclass(frozen=True)
class Alone:
    """Declarations' own findings (those of the chunks an edit changed) and what
    other declarations see of them."""

    diagnostics: list[Diagnostic]
    symbols: dict[str, Symbol]  # what they declare, in order
    uses: Counter[str]  # the names their references name, and how often
    edges: frozenset[str]  # the events they read (an emitted one: its transducer)
    nodes: frozenset[str]  # their names among those: an event's, a transducer's
    exported: dict[str, object]  # a variable's type and path, an event's type, by name
    lateness: dict[str, bool]  # by property: whether it has a `lateness` setting

    def declared(self, name: str) -> tuple[object, str | None]:
        symbol = self.symbols[name]
        return symbol.kind, symbol.owner


def checked_alone(
    model: Model,
    info: TypeInfo,
    decls: tuple[ast.Decl, ...],
    parsed: tuple[Diagnostic, ...],
    damaged: tuple[set[str], list[tuple[int, int]]] = (set(), []),
) -> Alone | None:
    """The declarations' own findings in `model` (those of the chunks an edit
    changed): their parse, their names and their types, checked on copies
    (`model` and `info` are left as they were). `damaged`: the names of those
    chunks with a syntax error, and where they are; what the check says of such
    a chunk (rmvdsl.check._quieted). None when they declare a name twice."""
    symbols = declared_by(decls)
    if symbols is None:
        return None
    names = NameChecker([], model.sources, damaged[0], {})
    names.model = dataclasses.replace(model, uses=[], _reads=None, unresolved=set())
    # Incremental: a declaration typed before is not typed again while what it
    # looked up is unchanged (rmvdsl.check.memo), its compiled formula reused.
    types = TypeChecker(names.model, TypeConfig(), ".", True, _typing_copy(info))
    edges: set[str] = set()
    exported: dict[str, object] = {}
    for decl in decls:
        names.check_decl(decl)
        reads = names.event_reads.get(id(decl))
        edges |= _edges(model, [i.name for i in reads] if reads is not None else _inputs(decl))
        found_type = _typed(types, decl)
        if found_type:
            exported[decl.name.name] = found_type  # type: ignore[attr-defined]

    def quieted(span: Span) -> bool:
        return any(start <= span.start < end for start, end in damaged[1])

    found = [*parsed]  # what follows from a missing part is not said
    found += [d for d in names.diagnostics if d.code not in CONSEQUENTIAL or not quieted(d.span)]
    found += [d for d in types.diagnostics if not quieted(d.span)]
    uses = Counter(r.name for r in cast("list[Reference]", names.model.uses))
    nodes = frozenset(
        d.name.name for d in decls if isinstance(d, ast.EventDecl | ast.TransducerDecl)
    )
    lateness = {
        d.name.name: any(s.key.name == "lateness" for s in d.settings)
        for d in decls
        if isinstance(d, ast.PropertyDecl)
    }
    return Alone(found, symbols, uses, frozenset(edges), nodes, exported, lateness)


def declared_by(decls: tuple[ast.Decl, ...]) -> dict[str, Symbol] | None:
    """The symbols declarations declare, in order; None when one is declared
    twice, or declaring one alone finds something wrong (a keyword as a name)."""
    symbols: dict[str, Symbol] = {}
    for decl in decls:
        found = _declared(decl)
        if found is None or found.keys() & symbols.keys():
            return None
        symbols.update(found)
    return symbols


def _declared(decl: ast.Decl) -> dict[str, Symbol] | None:
    """The symbols a declaration declares, in order, when declaring it alone finds
    nothing wrong (a keyword as a name, a state declared twice: None)."""
    alone = NameChecker([], SourceMap(), set(), {})
    alone.declare_all([decl])
    return None if alone.diagnostics else alone.model.symbols


def _inputs(decl: ast.Decl) -> list[str]:
    """The events a transducer's transitions read (rmvdsl.check.cycles)."""
    if not isinstance(decl, ast.TransducerDecl):
        return []
    return [t.input.name for t in decl.transitions]


def _edges(model: Model, read: list[str]) -> frozenset[str]:
    """What of `read` the cycles are searched along, as rmvdsl.check.cycles reads
    it: an event stands for itself, an emitted event for its transducer."""
    found = set()
    for name in read:
        if name in model.events:
            found.add(name)
        elif name in model.emitted:
            symbol = dict.get(model.symbols, name)
            if symbol is not None and symbol.owner is not None:
                found.add(symbol.owner)
    return frozenset(found)


def _typing_copy(info: TypeInfo) -> TypeInfo:
    """A TypeInfo to type one declaration in: what it writes goes to copies."""
    return TypeInfo(
        info.registry,
        info.topics,
        dict(info.variables),
        dict(info.events),
        dict(info.horizons),
        dict(info.paths),
        dict(info.formulas),
    )


def _typed(types: TypeChecker, decl: ast.Decl) -> tuple[object, ...]:
    """Type one declaration (as the types stage does); what it exports."""
    info = types.info
    match decl:
        case ast.VarDecl():
            name = decl.name.name
            info.paths.pop(name, None)
            return types.typed_variable(decl), info.paths.get(name)
        case ast.EventDecl():
            info.events.pop(decl.name.name, None)
            return (types.event_type(decl.name.name),)
        case ast.AlertDecl():
            types.check_alert(decl)
        case ast.PropertyDecl():
            types.check_property(decl)
    return ()


def exports_as_before(old: Alone, info: TypeInfo) -> bool:
    """Whether typing the old declarations again gave what the check gave them
    (a type does not depend on where typing began)."""
    for name, exported in old.exported.items():
        kind = old.symbols[name].kind
        if kind is Kind.VARIABLE:
            if exported != (info.variables.get(name), info.paths.get(name)):
                return False
        elif exported != (info.events.get(name),):
            return False
    return True


def declared_again(
    model: Model,
    old: tuple[tuple[ast.Decl, ...], Alone],
    new: tuple[tuple[ast.Decl, ...], dict[str, Symbol]],
    sources: SourceMap,
    moved: Sequence[tuple[int, int]],
) -> Model | None:
    """The model with the new declarations where the old ones were (a symbol
    declared by both in its place: the order of suggestions follows it), or None
    when an old one did not hold its names alone (a name declared twice, an
    event another transducer emits too). `moved`: where each changed group of
    chunks ended in the old text and how far the edits up to it moved the text
    after it (a symbol read there is read where it now stands)."""
    (old_decls, before), (new_decls, after) = old, new
    symbols = _Moved(model.symbols, moved)
    for name in before.symbols:
        known = dict.get(symbols, name)
        if known is None or known.decl is not before.symbols[name].decl:
            return None
        if name not in after:
            del symbols[name]
    for name, symbol in after.items():
        if name not in before.symbols and dict.__contains__(symbols, name):
            return None  # declared elsewhere too
        symbols[name] = symbol
        symbols.new.add(name)
    emitted = dict(model.emitted)
    for decl in old_decls:
        for transition in decl.transitions if isinstance(decl, ast.TransducerDecl) else ():
            if transition.output is not None:
                if len(emitted.get(transition.output.name, ())) != 1:
                    return None
                del emitted[transition.output.name]
    for decl in new_decls:
        for transition in decl.transitions if isinstance(decl, ast.TransducerDecl) else ():
            if transition.output is not None:
                emitted.setdefault(transition.output.name, []).append(transition)
    again = dataclasses.replace(
        model, sources=sources, symbols=symbols, emitted=emitted, uses=[], _reads=None
    )
    for group in {_GROUPS[type(d)] for d in (*old_decls, *new_decls)}:
        members = dict(getattr(model, group))
        for decl in old_decls:
            if _GROUPS[type(decl)] == group:
                members.pop(decl.name.name, None)  # type: ignore[attr-defined]
        for decl in new_decls:
            if _GROUPS[type(decl)] == group:
                members.setdefault(decl.name.name, decl)  # type: ignore[attr-defined]
        setattr(again, group, members)
    return again


class _Moved(dict[str, Symbol]):
    """The symbols of the old text read where they stand in the new one: each
    moved by the edits before it (`moved`: where each changed group of chunks
    ended in the old text, and how far the edits up to it moved what follows),
    those declared anew (`new`) as they are. Each one read is moved then: a check
    of one declaration reads a few."""

    def __init__(self, symbols: dict[str, Symbol], moved: Sequence[tuple[int, int]]) -> None:
        super().__init__(symbols)
        self.ends = [end for end, _ in moved]
        self.deltas = [delta for _, delta in moved]
        self.new: set[str] = set()

    def get(self, name: str, default: Any = None) -> Any:
        found = super().get(name)
        return default if found is None else self._moved(found)

    def __getitem__(self, name: str) -> Symbol:
        return self._moved(super().__getitem__(name))

    def _moved(self, symbol: Symbol) -> Symbol:
        after = bisect.bisect_right(self.ends, symbol.span.start)
        if not after or symbol.name in self.new or not self.deltas[after - 1]:
            return symbol
        return dataclasses.replace(symbol, span=symbol.span.shifted(self.deltas[after - 1]))


def same_interface(model: Model, old: Alone, new: Alone) -> bool:
    """Whether the other declarations' findings are as they were, but for which
    names are unused: a name declared by both declared alike and of the same
    type; a name no longer declared read by none of the others; a new name not
    declared before; no name read in vain that a name come or gone is, or whose
    "did you mean" it could choose or sway; no new event read that closes a cycle
    (the check before found none); and where RMV224 could be said, the same
    names read, declared and settings."""
    counts = use_counts(model)
    gone, come = old.symbols.keys() - new.symbols.keys(), new.symbols.keys() - old.symbols.keys()
    if (gone or come) and _suggestions_may_change(model.unresolved, gone | come):
        return False
    for name in gone:
        if counts[name] != old.uses[name]:
            return False
    for name in come:
        if name in model.symbols:
            return False
    for name in old.symbols.keys() & new.symbols.keys():
        if old.declared(name) != new.declared(name):
            return False
        if old.exported.get(name) != new.exported.get(name):
            return False
    if nothing_checked_after(model, old, new):
        return False
    added = new.edges - old.edges
    if added and _reaches(model, added, new.nodes | old.nodes):
        return False
    if not stamped_twice(model):
        return True
    same = (old.uses.keys(), old.symbols.keys(), old.lateness)
    return same == (new.uses.keys(), new.symbols.keys(), new.lateness)


def _suggestions_may_change(unresolved: set[str], changed: set[str]) -> bool:
    """Whether a name declared or no longer declared changes what is said of a
    name read in vain: it is that name, or its "did you mean" could choose it or
    be swayed by it (a name at the cutoff distance or farther never is)."""
    return any(
        name in unresolved or any(may_sway(wrong, name) for wrong in unresolved) for name in changed
    )


def nothing_checked_after(model: Model, old: Alone, new: Alone) -> bool:
    """Whether the edit leaves no property nor alert (RMV226 would be said: the
    check before checked something)."""
    if model.whitelists or model.nodes or model.intrusion is not None:
        return False
    kinds = (Kind.PROPERTY, Kind.ALERT)
    gone = sum(s.kind in kinds for s in old.symbols.values())
    come = sum(s.kind in kinds for s in new.symbols.values())
    return len(model.properties) + len(model.alerts) - gone + come == 0


def _reaches(model: Model, starts: frozenset[str], goals: frozenset[str]) -> bool:
    """Whether the events and transducers `starts` read one of `goals`, through
    others (an edge to them would close a cycle; no cycle runs through an alert,
    a property or a variable)."""
    pending, seen = list(starts), set(starts)
    while pending:
        name = pending.pop()
        if name in goals:
            return True
        decl = model.events.get(name) or model.transducers.get(name)
        if decl is None:
            continue
        for read in _edges(model, _reads_of(model, decl)) - seen:
            seen.add(read)
            pending.append(read)
    return False


def _reads_of(model: Model, decl: ast.Decl) -> list[str]:
    """The names an event reads (as its names check last found them, else checked
    again), or a transducer's transitions."""
    if not isinstance(decl, ast.EventDecl):
        return _inputs(decl)
    kept = findings(decl)
    known = None if kept is None else kept.get(("names", model.time_unit))
    if isinstance(known, Resolved) and known.reads is not None:
        return [ident.name for ident in known.reads]
    names = NameChecker([], model.sources, set(), {})
    names.model = dataclasses.replace(model, uses=[], _reads=None)
    names.check_decl(decl)
    return [ident.name for ident in names.event_reads.get(id(decl), ())]


def stamped_twice(model: Model) -> bool:
    """Whether two topics are timed by their header stamps (RMV224 reads them)."""
    stamped = 0
    for decl in model.topics.values():
        setting = decl.time_setting
        stamped += setting is not None and setting.ident.name == "header"
    return stamped >= 2
