"""The system a spec's properties are checked on: its transducers as machines, and the
boolean events that can never hold, or never together (asked of z3 once per pair
that shares a variable)."""

from __future__ import annotations

import itertools

from rmvdsl.check.analysis import AnalysisResult
from rmvdsl.check.conditions import Conditions
from rmvdsl.check.model import Kind, Model
from rmvdsl.logic.system import Machine, System


def system_of(
    model: Model,
    analysis: AnalysisResult | None,
    conditions: Conditions,
    names: set[str],
    skip: set[str],
) -> System:
    """The transducers, and the boolean events among `names` that can never hold,
    or never together."""
    machines = []
    unreachable: set[str] = set()
    for name, decl in model.transducers.items():
        if name in skip:
            continue
        states = tuple(s.name for s in decl.states)
        if len(set(states)) != len(states):
            continue  # the names stage reported it
        moves = frozenset(
            (t.source.name, t.dest.name) for t in decl.transitions if t.source.name != t.dest.name
        )
        # No initial state: at the input's first instant a transducer already takes
        # the transitions enabled then (docs/semantics.md, "Instants"), so a run's
        # first state is any the initial one reaches; those it cannot reach never
        # hold (below).
        machines.append(Machine(name, states, None, moves))
        # States the initial one cannot reach never hold (the refutation does not
        # follow transitions, so it is told).
        facts = analysis.transducers.get(name) if analysis is not None else None
        if facts is not None:
            unreachable.update(facts.unreachable)
    events = sorted(
        n for n in names if (s := model.symbols.get(n)) is not None and s.kind is Kind.BOOL_EVENT
    )
    never = {
        e for e in events if conditions.solve([conditions.of_event(e)], values=False)[0] == "unsat"
    }
    exclusive = {
        (a, b)
        for a, b in _sharing([e for e in events if e not in never], conditions)
        if conditions.solve([conditions.of_event(a), conditions.of_event(b)], values=False)[0]
        == "unsat"
    }
    return System(tuple(machines), frozenset(exclusive), frozenset(never | unreachable))


def _sharing(events: list[str], conditions: Conditions) -> list[tuple[str, str]]:
    """The pairs of events whose conditions read a common variable, in order: two
    satisfiable conditions over disjoint variables hold together, so only these
    pairs can exclude each other (what keeps the question from being quadratic in
    the events)."""
    readers: dict[str, list[int]] = {}
    for index, event in enumerate(events):
        for name in conditions.names_of_event(event):
            readers.setdefault(name, []).append(index)
    pairs = {(i, j) for group in readers.values() for i, j in itertools.combinations(group, 2)}
    return [(events[i], events[j]) for i, j in sorted(pairs)]
