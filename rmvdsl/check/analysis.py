"""Analyses (stage 4): the transducers, with networkx and z3.

- reachability from the initial state, dead ends, inputs nothing produces, outputs
  nothing consumes, transducers nothing observes (networkx);
- non-determinism: two transitions leaving one state on inputs that can hold at the
  same time, with the values that make them (z3); with `complete`, the inputs under
  which a state has no transition.

Boolean events are conditions over variables, as z3 formulas with the runtime's
operator semantics (rmvdsl/check/conditions.py, rmvdsl/check/operators.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import z3

from rmvdsl.check.conditions import Conditions
from rmvdsl.check.impossible import impossible
from rmvdsl.check.model import Model
from rmvdsl.check.types import TypeInfo
from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.lang.diagnostics import Diagnostic, Label, error, warning
from rmvdsl.logic.terms import Z3_VERSION
from rmvdsl.util.cache import default_cache, digest
from rmvdsl.util.cancel import checkpoint

if TYPE_CHECKING:  # imported where a transducer's graph is made: a spec with no
    import networkx as nx  # transducer loads none of it (75 ms of its import here)


@dataclass
class TransducerFacts:
    """What the analyses found, for `rmv graph` and the editor."""

    unreachable: set[str] = field(default_factory=set)
    dead_ends: set[str] = field(default_factory=set)
    conflicts: list[tuple[ast.Transition, ast.Transition, str]] = field(default_factory=list)


@dataclass
class AnalysisResult:
    transducers: dict[str, TransducerFacts] = field(default_factory=dict)


def _unreachable(decl: ast.TransducerDecl, graph: nx.MultiDiGraph, untaken: set[int]) -> set[str]:
    """The states no path of takeable transitions leads to from the initial state."""
    import networkx as nx

    if decl.initial is None or decl.initial.name not in graph:
        return set()
    usable = nx.subgraph_view(
        graph, filter_edge=lambda a, b, key: id(graph.edges[a, b, key]["transition"]) not in untaken
    )
    reachable = nx.descendants(usable, decl.initial.name) | {decl.initial.name}
    return {s.name for s in decl.states} - reachable


class Analyzer:
    def __init__(
        self, model: Model, types: TypeInfo | None, broken: frozenset[str] = frozenset()
    ) -> None:
        self.model = model
        self.types = types
        self.broken = broken  # declarations with errors: nothing is claimed about them
        self.diagnostics: list[Diagnostic] = []
        self.result = AnalysisResult()
        self.conditions = Conditions(model, types)
        self._never: dict[str, str | None] = {}
        self._unsat: dict[str, bool] = {}

    def report(self, diagnostic: Diagnostic) -> None:
        self.diagnostics.append(diagnostic)

    def run(self) -> tuple[AnalysisResult, list[Diagnostic]]:
        graphs = {name: self.graph(decl) for name, decl in self.model.transducers.items()}
        for name in self.model.transducers:
            self.result.transducers[name] = TransducerFacts()
        untaken = self.untaken_transitions(graphs)
        silent = self.never_emitted()  # once: it reads every transducer
        for name, decl in self.model.transducers.items():
            checkpoint()  # the editor may stop here (rmvdsl.util.cancel)
            if name in self.broken:
                continue
            facts = self.result.transducers[name]
            self.reachability(decl, graphs[name], facts, untaken)
            self.determinism(decl, facts, silent)
            if decl.complete:
                self.completeness(decl)
        self.unproduced_inputs()
        used = self.used_names()
        self.unconsumed_outputs(used)
        self.unobserved_transducers(used)
        return self.result, self.diagnostics

    @staticmethod
    def graph(decl: ast.TransducerDecl) -> nx.MultiDiGraph:
        import networkx as nx

        graph = nx.MultiDiGraph()
        graph.add_nodes_from(s.name for s in decl.states)
        for transition in decl.transitions:
            graph.add_edge(transition.source.name, transition.dest.name, transition=transition)
        return graph

    def untaken_transitions(self, graphs: dict[str, nx.MultiDiGraph]) -> set[int]:
        """Transitions that can never be taken (by id): their input is a boolean event
        whose condition is unsatisfiable, or an event emitted only from states that
        cannot be reached. Reachability ignores them, so that a state reached only
        through them is unreachable, not a reachable dead end; computed to a fixpoint
        (an unreachable state silences what it emits, which may cut off more)."""
        inputs = [t.input.name for d in self.model.transducers.values() for t in d.transitions]
        self._ask_unsatisfiable(inputs)
        impossible = {name for name in inputs if self._unsat[name]}
        untaken: set[int] = set()
        while True:
            for name, decl in self.model.transducers.items():
                self.result.transducers[name].unreachable = _unreachable(
                    decl, graphs[name], untaken
                )
            silent = self.never_emitted() | impossible
            found = {
                id(t)
                for decl in self.model.transducers.values()
                for t in decl.transitions
                if t.input.name in silent
            }
            if found == untaken:
                return untaken
            untaken = found

    def _unsatisfiable(self, name: str) -> bool:
        """A boolean event whose condition no values make true."""
        self._ask_unsatisfiable([name])
        return self._unsat[name]

    def _ask_unsatisfiable(self, names: list[str]) -> None:
        """`_unsatisfiable` of these names, each asked once: its answer kept under the
        text of the question (a re-check builds no z3 term for it), and events whose
        questions read alike (rmvdsl.check.conditions.event_question) asked as one,
        the others together (rmvdsl.check.impossible)."""
        cache = default_cache()
        keys: dict[str, str] = {}
        for name in dict.fromkeys(names):
            decl = self.model.events.get(name)
            if name in self._unsat or decl is None or not decl.boolean:
                self._unsat.setdefault(name, False)
                continue
            key = digest("unsatisfiable event", "2", Z3_VERSION,
                         self.conditions.event_question(name))  # fmt: skip
            cached = cache.get(key)
            if cached is not None and isinstance(cached.get("unsat"), bool):
                self._unsat[name] = cached["unsat"]
            else:
                keys[name] = key
        alike: dict[str, list[str]] = {}  # a question -> its events, the first asked
        for name, key in keys.items():
            alike.setdefault(key, []).append(name)
        asked = [events[0] for events in alike.values()]
        for name, answer in impossible(asked, self.conditions).items():
            if answer is not None:  # a time limit is not an answer to keep
                cache.put(keys[name], {"unsat": answer})
            for event in alike[keys[name]]:
                self._unsat[event] = answer is True

    def reachability(
        self,
        decl: ast.TransducerDecl,
        graph: nx.MultiDiGraph,
        facts: TransducerFacts,
        untaken: set[int],
    ) -> None:
        if decl.initial is None or decl.initial.name not in graph:
            return
        plainly = _unreachable(decl, graph, set())
        finals = {f.name for f in decl.finals}
        for state in decl.states:
            if state.name in facts.unreachable:
                entries = [t for t in decl.transitions if t.dest.name == state.name]
                through = sorted({f"`{t.input.name}`" for t in entries if id(t) in untaken})
                label = (
                    f"no path from `{decl.initial.name}` leads here"
                    if state.name in plainly
                    else "entered only on " + ", ".join(through) + ", which never holds"
                )
                self.report(
                    error(
                        "RMV500",
                        f"state `{state.name}` of `{decl.name.name}` cannot be reached",
                        state.span,
                        label=label,
                        secondary=[Label(decl.initial.span, "the initial state")],
                        help=f"add a transition into `{state.name}`, or remove it"
                        if state.name in plainly
                        else "see why those inputs never hold (RMV502)",
                    )
                )
                continue
            exits = [t for t in decl.transitions if t.source.name == state.name]
            leaving = [t for t in exits if t.dest.name != state.name and id(t) not in untaken]
            if not leaving and state.name not in finals:
                facts.dead_ends.add(state.name)
                blocked = sorted({f"`{t.input.name}`" for t in exits if id(t) in untaken})
                self.report(
                    warning(
                        "RMV501",
                        f"state `{state.name}` of `{decl.name.name}` has no way out",
                        state.span,
                        label="its only ways out are on "
                        + ", ".join(blocked)
                        + ", which never holds"
                        if blocked
                        else "no transition leaves this state",
                        help=f"add a transition out of it, or declare it `final {state.name}`",
                    )
                )

    def determinism(
        self, decl: ast.TransducerDecl, facts: TransducerFacts, silent: set[str]
    ) -> None:
        """`silent`: the emitted events that are never emitted."""
        by_source: dict[str, list[ast.Transition]] = {}
        for transition in decl.transitions:
            if transition.input.name in silent:
                continue  # never taken (RMV502): no choice to make
            by_source.setdefault(transition.source.name, []).append(transition)
        for transitions in by_source.values():
            for index, first in enumerate(transitions):
                for second in transitions[index + 1 :]:
                    if first.dest.name == second.dest.name and first.output == second.output:
                        continue  # both lead to the same place: no choice to make
                    self.conflict(decl, first, second, facts)

    def conflict(
        self,
        decl: ast.TransducerDecl,
        first: ast.Transition,
        second: ast.Transition,
        facts: TransducerFacts,
    ) -> None:
        if first.input.name == second.input.name:
            values = f"whenever `{first.input.name}` holds"
        else:
            both = (
                self.conditions.of_event(first.input.name),
                self.conditions.of_event(second.input.name),
            )
            answer, found = self.conditions.solve(list(both))
            if answer != "sat":
                return  # unsat: they exclude each other; unknown: no claim either way
            values = f"for example when {found or 'any values'}"
        facts.conflicts.append((first, second, values))
        self.report(
            error(
                "RMV505",
                f"`{decl.name.name}` is not deterministic in `{first.source.name}`: "
                f"`{first.input.name}` and `{second.input.name}` can hold at the same time",
                second.span,
                label=f"goes to `{second.dest.name}` on `{second.input.name}`",
                secondary=[
                    Label(first.span, f"goes to `{first.dest.name}` on `{first.input.name}`")
                ],
                help=f"{values}; make the conditions exclusive, e.g. add `and not "
                f"{first.input.name}` to the condition of `{second.input.name}`",
            )
        )

    def completeness(self, decl: ast.TransducerDecl) -> None:
        for state in decl.states:
            inputs = [t.input.name for t in decl.transitions if t.source.name == state.name]
            if state.name in {f.name for f in decl.finals}:
                continue
            none = (
                z3.Not(z3.Or(*[self.conditions.of_event(i) for i in inputs]))
                if inputs
                else z3.BoolVal(True)
            )
            # Once a topic has published its values stay: only the initial state
            # can meet a value that is not there yet.
            answer, found = self.conditions.solve([none, self.conditions.present([none])])
            initial = decl.initial is not None and decl.initial.name == state.name
            if answer != "sat" and initial:
                answer, found = self.conditions.solve([none])
            if answer != "sat":
                continue
            values = (found or "any values") if inputs else "any values"
            self.report(
                warning(
                    "RMV506",
                    f"`{decl.name.name}` is marked complete, but `{state.name}` has no transition "
                    f"when {values}",
                    state.span,
                    label="no input applies here then",
                    help="add a transition for those inputs, or drop `complete`",
                )
            )

    def never_emitted(self) -> set[str]:
        """Emitted events whose every emitting transition leaves an unreachable state."""
        silent = set()
        for name, transitions in self.model.emitted.items():
            owner = self.model.symbols[name].owner or ""
            facts = self.result.transducers.get(owner)
            if facts is not None and all(t.source.name in facts.unreachable for t in transitions):
                silent.add(name)
        return silent

    def unproduced_inputs(self) -> None:
        silent = self.never_emitted()
        reachable_emitters = {name: name not in silent for name in self.model.emitted}
        for owner, decl in self.model.transducers.items():
            if owner in self.broken:
                continue
            for transition in decl.transitions:
                name = transition.input.name
                reason = self.never_holds(name, reachable_emitters)
                if reason is None:
                    continue
                self.report(
                    warning(
                        "RMV502",
                        f"the input `{name}` of `{transition.source.name} -> "
                        f"{transition.dest.name}` never holds: {reason}",
                        transition.input.span,
                        label="this transition can never be taken",
                        help="fix the event's condition, or the transition",
                    )
                )

    def never_holds(self, name: str, reachable_emitters: dict[str, bool]) -> str | None:
        if name not in self._never:
            self._never[name] = self._never_holds(name, reachable_emitters)
        return self._never[name]

    def _never_holds(self, name: str, reachable_emitters: dict[str, bool]) -> str | None:
        if name in reachable_emitters:
            return (
                None
                if reachable_emitters[name]
                else "every transition emitting it starts in an unreachable state"
            )
        return "its condition is unsatisfiable" if self._unsatisfiable(name) else None

    def unconsumed_outputs(self, used: set[str]) -> None:
        for name, transitions in self.model.emitted.items():
            if name in used:
                continue
            first = transitions[0]
            assert first.output is not None
            self.report(
                warning(
                    "RMV503",
                    f"the output `{name}` is emitted but nothing uses it",
                    first.output.span,
                    label="no transition, property or alert reads this event",
                    help="use it as an input or in a property, or remove `emit`",
                )
            )

    def used_names(self) -> set[str]:
        used = {t.input.name for d in self.model.transducers.values() for t in d.transitions}
        for prop in self.model.properties.values():
            if prop.formula is not None:
                used |= {p.name for p in fm.propositions(prop.formula)}
            used |= {
                s.value.ident.name for s in prop.settings if isinstance(s.value, ast.NameValue)
            }
        for alert in self.model.alerts.values():
            for level in alert.levels:
                used |= ast.names_in(level.condition) | (
                    ast.names_in(level.reset) if level.reset else set()
                )
        for event in self.model.events.values():
            used |= ast.names_in(event.expr)
        return used

    def unobserved_transducers(self, used: set[str]) -> None:
        if any(prop.formula is None for prop in self.model.properties.values()):
            return  # a property that does not parse may be the one looking
        inputs = {t.input.name for d in self.model.transducers.values() for t in d.transitions}
        observed = used - inputs
        for decl in self.model.transducers.values():
            states = {s.name for s in decl.states}
            outputs = {t.output.name for t in decl.transitions if t.output is not None}
            if (states | outputs) & observed:
                continue
            self.report(
                warning(
                    "RMV504",
                    f"no property or alert looks at transducer `{decl.name.name}`",
                    decl.name.span,
                    label="its states and outputs are never used",
                    help="write a property over its states, e.g. `property P: always[<=10s] "
                    f"not {decl.states[0].name if decl.states else 'S'}`",
                )
            )


def analyze(
    model: Model, types: TypeInfo | None, broken: set[str] | frozenset[str] = frozenset()
) -> tuple[AnalysisResult, list[Diagnostic]]:
    """The transducer analyses, on the declarations not in `broken`."""
    return Analyzer(model, types, frozenset(broken)).run()
