"""Analyses (stage 4, continued): the properties, with `rmvdsl.logic.sat`.

For each property: can it hold at all (in pure logic, and on the traces this
system can make)? Can it fail? Does an implication in it have an antecedent that
never holds? For all properties together: can they hold at once (if not, a
smallest conflicting subset)? Is one implied by the others?

Only exact answers become warnings or errors. An undecided question is a note
when the solver's time limit cut it short; a bounded search that found nothing
claims nothing.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from rmvdsl.check.analysis import AnalysisResult
from rmvdsl.check.conditions import Conditions
from rmvdsl.check.model import Model
from rmvdsl.check.property_findings import PropertyFacts, PropertyFindings, PropertyReport
from rmvdsl.check.property_system import system_of
from rmvdsl.check.types import TypeInfo
from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.grammar.printer import formula as show_formula
from rmvdsl.lang.diagnostics import Diagnostic, Label, error, warning
from rmvdsl.logic.answers import NO, UNKNOWN, YES, Witness
from rmvdsl.logic.canonical import keep_at_least
from rmvdsl.logic.compile import CompileError, compile_formula
from rmvdsl.logic.parallel import Question, answer_all, implied_all
from rmvdsl.logic.sat import Limits, satisfiable, valid
from rmvdsl.logic.sat import conflict as smallest_conflict
from rmvdsl.logic.system import System
from rmvdsl.runtime.rmtld3 import facts as formula_facts
from rmvdsl.util.cache import Cache, Layered, default_cache
from rmvdsl.util.cancel import checkpoint

# Redundancy costs one question per property over all the others (0.1-0.4 s each
# with 20 to 40 properties): past this many properties it is skipped, as
# docs/verification.md and RMV515 say.
REDUNDANCY_LIMIT = 24


def analyze_properties(
    model: Model,
    types: TypeInfo | None,
    analysis: AnalysisResult | None,
    skip: set[str],
    limits: Limits | None = None,
    cache: Cache | None = None,
) -> PropertyReport:
    """`skip`: properties and transducers that earlier stages found wrong (they may
    not mean what they say): such properties are not analysed, such transducers
    constrain nothing."""
    return _PropertyAnalyzer(model, types, analysis, skip, limits or Limits(), cache).run()


class _PropertyAnalyzer(PropertyFindings):
    def __init__(
        self,
        model: Model,
        types: TypeInfo | None,
        analysis: AnalysisResult | None,
        skip: set[str],
        limits: Limits,
        cache: Cache | None,
    ) -> None:
        self.model = model
        self.limits = limits
        self.cache = Layered(below=cache if cache is not None else default_cache())
        self.report = PropertyReport()
        # traces found by the joint questions, by the group they were asked of
        self.pool: dict[tuple[str, ...], list[Witness]] = {}
        self.compiled: dict[str, Any] = {}
        self._antecedents: dict[str, list[tuple[fm.Binary, Any]]] = {}
        # compiled once, by the types stage; absent when it does not compile (reported)
        formulas = types.formulas if types is not None else {}
        for name in model.properties:
            if name not in skip and name in formulas:
                self.compiled[name] = formulas[name]
        names = {n for f in self.compiled.values() for n in formula_facts(f).propositions}
        self.system = system_of(model, analysis, Conditions(model, types), names, skip)

    def compile(self, node: fm.Formula | fm.Term) -> Any:
        return compile_formula(node, Fraction(1), self.model.time_unit or "s")

    def add(self, diagnostic: Diagnostic) -> None:
        self.report.diagnostics.append(diagnostic)

    def run(self) -> PropertyReport:
        """The questions on each property, then on each group of them. Each step's
        questions are independent of each other: they are answered in parallel
        first (rmvdsl.logic.parallel), then read in order from the answers."""
        singles = [self.single_questions(name, f) for name, f in self.compiled.items()]
        keep_at_least(sum(len(questions) for questions in singles))
        self.prefetch(singles)
        consistent_candidates = []
        for name, f in self.compiled.items():
            checkpoint()  # the editor may stop here (rmvdsl.util.cancel)
            facts = PropertyFacts(f)
            self.report.facts[name] = facts
            if self.single(name, f, facts):
                consistent_candidates.append(name)
        # Properties sampled at a rate see the trace at its ticks only, not the one a
        # property without a rate sees: their verdicts are compared within one
        # sampling, never across (a change between two ticks is seen by one alone).
        samplings: dict[str, list[str]] = {}
        for name in consistent_candidates:
            samplings.setdefault(self.sampling(name), []).append(name)
        groups = [g for names in samplings.values() for g in self.groups(names) if len(g) > 1]
        self.prefetch([[([self.compiled[n] for n in g], self.system)] for g in groups])
        self.redundancy([g for g in groups if self.together(g)])
        return self.report

    def sampling(self, name: str) -> str:
        """How the property's monitor reads the trace: its `rate`, or "" (every change).
        A monitor started late by its trigger reads a past of its own: it is compared
        with no other."""
        if self.starts_late(name):
            return f"trigger {name}"
        decl = self.model.properties[name]
        rate = next((s.value for s in decl.settings if s.key.name == "rate"), None)
        return str(rate.hertz) if isinstance(rate, ast.RateLit) else ""

    def prefetch(self, batches: list[list[Question]]) -> None:
        """Answer these questions in parallel; the answers a time limit cut short
        are kept for this check only."""
        for key, answer in answer_all(batches, self.limits, self.cache).items():
            if answer.timed_out:
                self.cache.memory[key] = answer.as_json()

    def single_questions(self, name: str, f: Any) -> list[Question]:
        """What `single` and `vacuity` ask of one property, on its system: can it
        hold, can it fail, can each antecedent hold (answered by the traces of
        the first two where one does: see `vacuity`)."""
        system = self.system_for(name)
        decl = self.model.properties[name]
        antecedents: list[Question] = [([a], system, True) for _, a in self.antecedents(decl)]
        return [([f], system), ([("not", f)], system), *antecedents]

    def starts_late(self, name: str) -> bool:
        """A property under a trigger whose formula looks back: its monitor starts
        when the trigger holds, and its past begins there (docs/runtime.md), in
        whatever state the system is then."""
        decl = self.model.properties[name]
        trigger = next((s.value for s in decl.settings if s.key.name == "trigger"), None)
        return (
            isinstance(trigger, ast.NameValue)
            and trigger.ident.name != "always"
            and formula_facts(self.compiled[name]).has_past
        )

    def system_for(self, name: str) -> System:
        """The traces a property's monitor reads: from the start of the system, or,
        started late, from any state on."""
        return self.system.from_any_state() if self.starts_late(name) else self.system

    def antecedents(self, decl: ast.PropertyDecl) -> list[tuple[fm.Binary, Any]]:
        """The implications of a property, each with its antecedent compiled (once:
        the questions are asked ahead, then read)."""
        name = decl.name.name
        if name not in self._antecedents:
            self._antecedents[name] = self._compiled_antecedents(decl)
        return self._antecedents[name]

    def _compiled_antecedents(self, decl: ast.PropertyDecl) -> list[tuple[fm.Binary, Any]]:
        assert decl.formula is not None
        found = []
        for node in fm.walk(decl.formula):
            if isinstance(node, fm.Binary) and node.op == "->":
                try:
                    found.append((node, self.compile(node.left)))
                except CompileError:
                    continue
        return found

    def groups(self, names: list[str]) -> list[list[str]]:
        """The properties in groups that share propositions, in their order.

        Properties over disjoint propositions (a transducer's states, and events
        that exclude each other, counting as one) cannot conflict, nor imply one
        another unless one is valid or impossible alone (asked before): traces of
        each group combine into one trace. Looking into the past is the exception:
        a past operator can bound the time of evaluation (at t < 3, say), which
        another group may need later, so the properties that look into the past
        are one group with every other. Asking per group keeps the questions on all
        properties linear in their number, not quadratic (docs/verification.md)."""
        if any(formula_facts(self.compiled[n]).has_past for n in names):
            return [names]
        parent: dict[str, str] = {}

        def root(name: str) -> str:
            while parent.setdefault(name, name) != name:
                parent[name] = parent[parent[name]]
                name = parent[name]
            return name

        def join(a: str, b: str) -> None:
            parent[root(a)] = root(b)

        for machine in self.system.transducers:
            for state in machine.states[1:]:
                join(state, machine.states[0])
        for a, b in self.system.exclusive:
            join(a, b)
        grouped: dict[str, list[str]] = {}
        for name in names:
            propositions = sorted(formula_facts(self.compiled[name]).propositions)
            for other in propositions[1:]:
                join(other, propositions[0])
            # a property over no proposition is valid or impossible: a group alone
            key = propositions[0] if propositions else f" {name}"
            grouped.setdefault(key, []).append(name)
        merged: dict[str, list[str]] = {}
        for key, members in grouped.items():
            merged.setdefault(root(key), []).extend(members)
        order = {n: i for i, n in enumerate(names)}
        return sorted(
            (sorted(g, key=order.__getitem__) for g in merged.values()), key=lambda g: order[g[0]]
        )

    # ---- one property ----

    def single(self, name: str, f: Any, facts: PropertyFacts) -> bool:
        """The questions on one property; True when it can hold and can fail."""
        decl = self.model.properties[name]
        where = decl.name.span
        system = self.system_for(name)
        facts.satisfiable = answer = satisfiable([f], system, self.limits, self.cache)
        if answer.value == NO:
            pure = satisfiable([f], None, self.limits, self.cache)
            if pure.value != NO:  # exact on this system, whatever pure logic says
                self.add(self.impossible(decl, pure.witness, system))
            else:
                self.add(
                    error(
                        "RMV510",
                        f"property `{name}` can never hold: its monitor reports a violation "
                        "on every run",
                        where,
                        label="no trace makes this true",
                        help="check the bounds and the connectives; `rmv sat --formula` "
                        "answers the same question for a piece of it",
                    )
                )
            return False
        if answer.value == UNKNOWN:
            if answer.timed_out:
                self.add(self.undecided(decl, "can hold", answer))
            return False
        facts.valid = validity = valid(f, system, self.limits, self.cache)
        vacuous = self.vacuity(decl, [a.witness for a in (answer, validity) if a.witness])
        if validity.value == YES and vacuous:
            return False  # the vacuous implication says why
        if validity.value == YES:
            scope = ""
            if system.relevant(set(formula_facts(f).propositions)):
                pure = valid(f, None, self.limits, self.cache)
                scope = "" if pure.value == YES else " of this system"
            self.add(
                warning(
                    "RMV512",
                    f"property `{name}` holds on every trace{scope}: its monitor can never fire",
                    where,
                    label="true whatever happens",
                    help="a monitor that cannot fire gives false assurance: "
                    "strengthen the formula, or drop it",
                )
            )
            return False
        if validity.value == UNKNOWN and validity.timed_out:
            self.add(self.undecided(decl, "can fail", validity))
        return True

    def vacuity(self, decl: ast.PropertyDecl, known: list[Witness]) -> bool:
        """Report implications whose antecedent never holds; True if there are any.
        `known`: the property's traces (where it holds, where it fails): the one
        where an implication fails holds its antecedent, so most antecedents need
        no solver (bench_check's spec: none of its 500). A worker answered them so
        in the property's batch; what it left (without workers: all) is answered
        here the same way."""
        found = False
        system = self.system_for(decl.name.name)
        for node, antecedent in self.antecedents(decl):
            answer = satisfiable([antecedent], system, self.limits, self.cache, known)
            if answer.value != NO:
                continue
            found = True
            self.add(
                warning(
                    "RMV513",
                    f"in property `{decl.name.name}`, `{show_formula(node.left)}` can never "
                    "hold: the implication is vacuously true",
                    node.left.span,
                    label="never holds",
                    help="the implication says nothing; check the antecedent's states and bounds",
                )
            )
        return found

    # ---- all properties ----

    def together(self, names: list[str]) -> bool:
        formulas = [self.compiled[n] for n in names]
        answer = satisfiable(formulas, self.system, self.limits, self.cache)
        if answer.witness is not None:
            self.pool.setdefault(tuple(names), []).append(answer.witness)
        if answer.value != NO:
            return answer.value == YES
        core = smallest_conflict(formulas, self.system, self.limits)
        members = [names[i] for i in core] or names
        first, *others = members
        self.add(
            error(
                "RMV514",
                f"properties {', '.join(f'`{m}`' for m in members)} cannot hold together: "
                "on every run one of their monitors reports a violation",
                self.model.properties[first].name.span,
                label="conflicts with the others",
                secondary=[
                    Label(self.model.properties[m].name.span, "member of the conflict")
                    for m in others
                ],
                help="each can hold alone; weaken one of them, or check their bounds",
            )
        )
        return False

    def known_traces(self, group: tuple[str, ...]) -> list[Witness]:
        """The traces found so far for the group's properties (witnesses and
        counterexamples): those of other groups leave its propositions out."""
        found = list(self.pool.get(group, ()))
        for name in group:
            facts = self.report.facts[name]
            for answer in (facts.satisfiable, facts.valid):
                if answer is not None and answer.witness is not None:
                    found.append(answer.witness)
        return found

    def redundancy(self, groups: list[list[str]]) -> None:
        """RMV515 for each property the others of its group imply (the groups of at
        most REDUNDANCY_LIMIT properties that can hold together)."""
        asked = [
            (g, [self.compiled[n] for n in g], self.known_traces(tuple(g)))
            for g in groups
            if len(g) <= REDUNDANCY_LIMIT
        ]
        for group in groups:
            if len(group) > REDUNDANCY_LIMIT:  # said, never silently skipped
                self.add(self.redundancy_skipped(group, REDUNDANCY_LIMIT))
        for found in implied_all(asked, self.system, self.limits, self.cache):
            for name, implied_by in found:
                self.add(self.implied(name, implied_by))
