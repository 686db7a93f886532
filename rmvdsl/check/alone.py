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
from typing import TYPE_CHECKING, cast

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
    """One declaration's own findings and what other declarations see of it."""

    diagnostics: list[Diagnostic]
    declared: tuple[tuple[str, object, str | None], ...]  # name, kind, owner
    uses: Counter[str]  # the names its references name, and how often
    edges: frozenset[str]  # the events it reads (an emitted one: its transducer)
    node: str | None  # its name among those: an event's, a transducer's
    exported: tuple[object, ...]  # a variable's type and path, an event's type
    lateness: bool  # a property with a `lateness` setting


def checked_alone(
    model: Model, info: TypeInfo, decl: ast.Decl, parsed: tuple[Diagnostic, ...]
) -> Alone | None:
    """The declaration's own findings in `model`: its chunk's parse, its names and
    its types, checked on copies (`model` and `info` are left as they were)."""
    symbols = _declared(decl)
    if symbols is None:
        return None
    declared = tuple((s.name, s.kind, s.owner) for s in symbols.values())
    names = NameChecker([], model.sources, set(), {})
    names.model = dataclasses.replace(model, uses=[], _reads=None)
    names.check_decl(decl)
    reads = names.event_reads.get(id(decl))
    edges = _edges(model, [i.name for i in reads] if reads is not None else _inputs(decl))
    # Incremental: a declaration typed before is not typed again while what it
    # looked up is unchanged (rmvdsl.check.memo), its compiled formula reused.
    types = TypeChecker(names.model, TypeConfig(), ".", True, _typing_copy(info))
    exported = _typed(types, decl)
    lateness = isinstance(decl, ast.PropertyDecl) and any(
        s.key.name == "lateness" for s in decl.settings
    )
    found = [*parsed, *names.diagnostics, *types.diagnostics]
    uses = Counter(r.name for r in cast("list[Reference]", names.model.uses))
    node = decl.name.name if isinstance(decl, ast.EventDecl | ast.TransducerDecl) else None
    return Alone(found, declared, uses, edges, node, exported, lateness)


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


def exports_as_before(old: Alone, decl: ast.Decl, info: TypeInfo) -> bool:
    """Whether typing the old declaration again gave what the check gave it (its
    type does not depend on where typing began)."""
    match decl:
        case ast.VarDecl():
            name = decl.name.name
            return old.exported == (info.variables.get(name), info.paths.get(name))
        case ast.EventDecl():
            return old.exported == (info.events.get(decl.name.name),)
    return True


def declared_again(model: Model, old: ast.Decl, new: ast.Decl, sources: SourceMap) -> Model | None:
    """The model with `new` declared where `old` was (its symbols in their places:
    the order of suggestions follows it), or None when `old` did not hold its
    names alone (a name declared twice, an event another transducer emits too)."""
    symbols = dict(model.symbols)
    for name, symbol in (_declared(new) or {}).items():
        if symbols.get(name) is None or symbols[name].decl is not _declarer(old, name):
            return None
        symbols[name] = symbol
    emitted = dict(model.emitted)
    if isinstance(new, ast.TransducerDecl) and isinstance(old, ast.TransducerDecl):
        for transition in old.transitions:
            if transition.output is not None and len(emitted[transition.output.name]) != 1:
                return None
        for transition in new.transitions:
            if transition.output is not None:
                emitted[transition.output.name] = [transition]
    again = dataclasses.replace(
        model, sources=sources, symbols=symbols, emitted=emitted, uses=[], _reads=None
    )
    group = _GROUPS[type(new)]
    setattr(again, group, {**getattr(model, group), new.name.name: new})  # type: ignore[attr-defined]
    return again


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
    if added and _reaches(model, added, new.node):
        return False
    return old.uses.keys() == new.uses.keys() or not _stamped_twice(model)


def _reaches(model: Model, starts: frozenset[str], goal: str | None) -> bool:
    """Whether the events and transducers `starts` read `goal`, through others
    (an edge to them would close a cycle)."""
    if goal is None:
        return False  # an alert, a property, a variable: no cycle runs through them
    pending, seen = list(starts), set(starts)
    while pending:
        name = pending.pop()
        if name == goal:
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


def _stamped_twice(model: Model) -> bool:
    """Whether two topics are timed by their header stamps (RMV224 reads them)."""
    stamped = 0
    for decl in model.topics.values():
        setting = decl.time_setting
        stamped += setting is not None and setting.ident.name == "header"
    return stamped >= 2


def unused_changes(
    model: Model, old: Alone, new: Alone
) -> tuple[list[Diagnostic], list[Diagnostic]]:
    """The RMV203 warnings the edit ends and those it starts (where the names
    stood before it): a name only the declaration used, no longer used, and a
    name nothing used, now used."""
    dropped = old.uses.keys() - new.uses.keys()
    added = new.uses.keys() - old.uses.keys()
    if not dropped and not added:
        return [], []
    counts = _use_counts(model)
    whitelisted = whitelisted_topics(model) if model.whitelists else set()
    ended, started = [], []
    for name in added:
        if counts[name] == 0:
            ended.append(unused_warning(model.symbols[name], whitelisted))
    for name in dropped:
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
