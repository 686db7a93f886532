"""One declaration checked alone, against the model and the types of a check of
the whole spec: its own findings (its chunk's parse, its names, its types) and
what the other declarations see of it (rmvdsl.check.edit compares the two of an
edited declaration). Checked on copies: the model and the types are left as
they were, for the editor reads them meanwhile."""

from __future__ import annotations

import dataclasses
import weakref
from collections import Counter
from dataclasses import dataclass
from operator import itemgetter
from typing import TYPE_CHECKING, Any, cast

from rmvdsl.check import CONSEQUENTIAL
from rmvdsl.check.model import Model, Reference, ReusedReferences, Symbol
from rmvdsl.check.names import (
    NameChecker,
    Resolved,
    unused_warning,
    whitelisted_topics,
)
from rmvdsl.check.typeinfo import TypeInfo
from rmvdsl.check.types import TypeChecker, TypeConfig
from rmvdsl.grammar import ast
from rmvdsl.grammar.shift import findings
from rmvdsl.lang.diagnostics import Diagnostic
from rmvdsl.lang.source import SourceMap

if TYPE_CHECKING:
    from rmvdsl.check import CheckResult

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
    """A chunk's declarations' own findings and what other declarations see of
    them."""

    diagnostics: list[Diagnostic]
    declared: tuple[tuple[str, object, str | None], ...]  # name, kind, owner
    uses: Counter[str]  # the names their references name, and how often
    edges: frozenset[str]  # the events they read (an emitted one: its transducer)
    nodes: frozenset[str]  # their names among those: an event's, a transducer's
    exported: tuple[object, ...]  # each one's: a variable's type and path, an event's type
    lateness: tuple[bool, ...]  # each one's: a property with a `lateness` setting


def checked_alone(
    model: Model,
    info: TypeInfo,
    decls: tuple[ast.Decl, ...],
    parsed: tuple[Diagnostic, ...],
    damaged: set[str] | None = None,
) -> Alone | None:
    """The declarations' own findings in `model` (those of one chunk): its parse,
    their names and their types, checked on copies (`model` and `info` are left
    as they were). `damaged`: the names of the chunk when it has a syntax error;
    then what the check says of it (rmvdsl.check._quieted)."""
    declared: list[tuple[str, object, str | None]] = []
    for decl in decls:
        symbols = _declared(decl)
        if symbols is None:
            return None
        declared += [(s.name, s.kind, s.owner) for s in symbols.values()]
    names = NameChecker([], model.sources, damaged or set(), {})
    names.model = dataclasses.replace(model, uses=[], _reads=None, unresolved=set())
    # Incremental: a declaration typed before is not typed again while what it
    # looked up is unchanged (rmvdsl.check.memo), its compiled formula reused.
    types = TypeChecker(names.model, TypeConfig(), ".", True, _typing_copy(info))
    edges: set[str] = set()
    exported = []
    for decl in decls:
        names.check_decl(decl)
        reads = names.event_reads.get(id(decl))
        edges |= _edges(model, [i.name for i in reads] if reads is not None else _inputs(decl))
        exported.append(_typed(types, decl))
    found = [*parsed, *names.diagnostics]
    if damaged is not None:  # what follows from a missing part is not said
        found = [d for d in found if d.code not in CONSEQUENTIAL or d in parsed]
    else:
        found += types.diagnostics
    uses = Counter(r.name for r in cast("list[Reference]", names.model.uses))
    nodes = frozenset(
        d.name.name for d in decls if isinstance(d, ast.EventDecl | ast.TransducerDecl)
    )
    lateness = tuple(
        isinstance(d, ast.PropertyDecl) and any(s.key.name == "lateness" for s in d.settings)
        for d in decls
    )
    return Alone(found, tuple(declared), uses, frozenset(edges), nodes, tuple(exported), lateness)


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
    """What of `read` the cycles are searched along: events, and the transducers
    of emitted events (rmvdsl.check.cycles)."""
    emitted = model.emitted
    return frozenset(
        name if name in model.events else emitted[name][0].output.name  # type: ignore[union-attr]
        for name in read
        if name in model.events or name in emitted
    )


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


def exports_as_before(old: Alone, decls: tuple[ast.Decl, ...], info: TypeInfo) -> bool:
    """Whether typing the old declarations again gave what the check gave them
    (a type does not depend on where typing began)."""
    for exported, decl in zip(old.exported, decls, strict=True):
        match decl:
            case ast.VarDecl():
                name = decl.name.name
                if exported != (info.variables.get(name), info.paths.get(name)):
                    return False
            case ast.EventDecl():
                if exported != (info.events.get(decl.name.name),):
                    return False
    return True


def declared_again(
    model: Model,
    old: tuple[ast.Decl, ...],
    new: tuple[ast.Decl, ...],
    sources: SourceMap,
    moved: tuple[int, int],
) -> Model | None:
    """The model with each of `new` declared where the one of `old` was (their
    symbols in their places: the order of suggestions follows it), or None when
    one of `old` did not hold its names alone (a name declared twice, an event
    another transducer emits too). `moved`: where the old text's rest began and
    how far the edit moved it (a symbol read there is read where it now stands)."""
    symbols, emitted = _Moved(model.symbols, *moved), dict(model.emitted)
    groups: dict[str, dict[str, ast.Decl]] = {}
    for before, after in zip(old, new, strict=True):
        for name, symbol in (_declared(after) or {}).items():
            known = dict.get(symbols, name)
            if known is None or known.decl is not _declarer(before, name):
                return None
            symbols[name] = symbol
            symbols.new.add(name)
        if isinstance(after, ast.TransducerDecl) and isinstance(before, ast.TransducerDecl):
            for transition in before.transitions:
                if transition.output is not None and len(emitted[transition.output.name]) != 1:
                    return None
            for transition in after.transitions:
                if transition.output is not None:
                    emitted[transition.output.name] = [transition]
        group = _GROUPS[type(after)]
        if group not in groups:
            groups[group] = dict(getattr(model, group))
        groups[group][after.name.name] = after  # type: ignore[attr-defined]
    again = dataclasses.replace(
        model, sources=sources, symbols=symbols, emitted=emitted, uses=[], _reads=None
    )
    for group, decls in groups.items():
        setattr(again, group, decls)
    return again


class _Moved(dict[str, Symbol]):
    """The symbols of the old text read where they stand in the new one: those
    after the edited chunk (from `after`) moved by `delta`, those declared anew
    (`new`) as they are. Each one read is moved then: a check of one declaration
    reads a few."""

    def __init__(self, symbols: dict[str, Symbol], after: int, delta: int) -> None:
        super().__init__(symbols)
        self.after, self.delta = after, delta
        self.new: set[str] = set()

    def get(self, name: str, default: Any = None) -> Any:
        found = super().get(name)
        return default if found is None else self._moved(found)

    def __getitem__(self, name: str) -> Symbol:
        return self._moved(super().__getitem__(name))

    def _moved(self, symbol: Symbol) -> Symbol:
        if not self.delta or symbol.span.start < self.after or symbol.name in self.new:
            return symbol
        return dataclasses.replace(symbol, span=symbol.span.shifted(self.delta))


def _declarer(decl: ast.Decl, name: str) -> ast.Node:
    """The node a symbol of `decl` is declared by (an emitted event's: its step)."""
    if isinstance(decl, ast.TransducerDecl):
        for transition in decl.transitions:
            if transition.output is not None and transition.output.name == name:
                return transition
    return decl


def same_interface(model: Model, old: Alone, new: Alone) -> bool:
    """Whether the other declarations' findings are as they were, but for which
    names are unused: the same names declared, the same types exported, no new
    event read (the check before found no cycle: fewer reads make none), and
    where RMV224 could be said, the same names read."""
    if (old.declared, old.exported, old.lateness) != (new.declared, new.exported, new.lateness):
        return False
    added = new.edges - old.edges
    if added and _reaches(model, added, new.nodes):
        return False
    return old.uses.keys() == new.uses.keys() or not stamped_twice(model)


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


def unused_changes(
    before: CheckResult, old: Alone, new: Alone, damaged: bool
) -> tuple[list[Diagnostic], list[Diagnostic]]:
    """The RMV203 warnings the edit ends and those it starts (where the names
    stood before it): a name only the declarations used, no longer used, and a
    name nothing used, now used. A text with a syntax error (`damaged`: the new
    one) reports none; after one, every unused name is reported again."""
    model = before.model
    if damaged:
        return [d for d in before.diagnostics if d.code == "RMV203"], []
    counts = _use_counts(model)
    whitelisted = whitelisted_topics(model) if model.whitelists else set()
    if any(model.damaged_ranges.values()):  # the check before reported none
        found = (
            unused_warning(symbol, whitelisted)
            for name, symbol in model.symbols.items()
            if counts[name] - old.uses[name] + new.uses[name] == 0
        )
        return [], [d for d in found if d]
    ended, started = [], []
    for name in new.uses.keys() - old.uses.keys():
        if counts[name] == 0:
            ended.append(unused_warning(model.symbols[name], whitelisted))
    for name in old.uses.keys() - new.uses.keys():
        if counts[name] == old.uses[name]:
            started.append(unused_warning(model.symbols[name], whitelisted))
    return [d for d in ended if d], [d for d in started if d]


# The model counted last (not kept alive by this: a closed document's is let go).
_COUNTED: list[tuple[weakref.ref[Model], Counter[str]]] = []


def prepare_edits(result: CheckResult) -> None:
    """Work out now what check_edit reads of `result` (an editor calls this beside
    the check, not at the next keystroke)."""
    _use_counts(result.model)


def _use_counts(model: Model) -> Counter[str]:
    """How often each name is referred to in the whole model (once per model)."""
    if _COUNTED and _COUNTED[0][0]() is model:
        return _COUNTED[0][1]
    counts: Counter[str] = Counter()
    for use in model.uses:
        if type(use) is ReusedReferences:
            counts.update(map(itemgetter(0), use.found))
        else:
            counts[cast("Reference", use).name] += 1
    _COUNTED[:] = [(weakref.ref(model), counts)]
    return counts
