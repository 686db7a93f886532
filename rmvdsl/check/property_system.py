"""The system a spec's properties are checked on: its transducers as machines, and the
boolean events that can never hold, or never together (rmvdsl.check.exclusion)."""

from __future__ import annotations

from rmvdsl.check.analysis import AnalysisResult
from rmvdsl.check.conditions import Conditions
from rmvdsl.check.exclusion import event_relations
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
    never, exclusive = event_relations(events, conditions)
    return System(tuple(machines), frozenset(exclusive), frozenset(never | unreachable))
