"""The two searches behind one satisfiability question (docs/verification.md): witness
traces (constant ones judged by the runtime's monitor, then k segments found by z3
and replayed through it, then periodic ones), and the refutation over all functions
of time."""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import z3

from rmvdsl.logic.abstract import refute
from rmvdsl.logic.answers import NO, UNKNOWN, YES, Answer, Witness
from rmvdsl.logic.bounded import BoundedTrace, EncodingTimeout
from rmvdsl.logic.limits import Limits
from rmvdsl.logic.system import System
from rmvdsl.logic.terms import assert_all, conjunction, disjunction, implication, negation
from rmvdsl.runtime.nesting import flattened
from rmvdsl.runtime.rmtld3 import Monitor, facts
from rmvdsl.runtime.segments import verdict_at
from rmvdsl.runtime.signal import plain
from rmvdsl.runtime.wording import counted
from rmvdsl.util.cancel import checkpoint

# The periodic witnesses (Question.periodic): at most this many propositions,
# half periods, and segments replayed in all.
PERIODIC_NAMES = 2
PERIODIC_PERIODS = 4
PERIODIC_BUDGET = 40_000
# The constant traces tried by the monitor before the solver (Question.constant).
CONSTANT_CANDIDATES = 64


class Question:
    """One question: are these formulas true together at one time of some trace of
    the system? `answer()` runs the searches, cheapest first, within the limits."""

    def __init__(self, formulas: list[Any], system: System, limits: Limits) -> None:
        self.formulas = [flattened(f) for f in formulas]  # the same meaning, fewer times
        self.system = system
        self.limits = limits
        found = [facts(f) for f in formulas]  # once: each is a walk of the formula
        self.mentioned = {name for f in found for name in f.propositions}
        self.names = sorted(system.names(self.mentioned))
        self.horizon = max((f.future for f in found), default=Fraction(0))
        self.looks_back = any(f.has_past for f in found)
        self.free_time = self.looks_back or any(
            m.initial is not None for m in system.relevant(self.mentioned)
        )
        self.timed_out = False
        self.replay_failures = 0

    def answer(self) -> Answer:
        """Witnesses with few changes first, then a quick refutation, then more
        changes, then the refutation with the whole limit: a satisfiable question
        rarely waits for a refutation that cannot succeed."""
        sizes = list(self.limits.segments)
        early, late = sizes[:3], sizes[3:]
        if 1 in sizes:
            found, complete = self.constant()
            if found is not None:
                return Answer(YES, True, found)
            if complete:
                early = [k for k in early if k != 1]
        for k in early:
            found = self.search(k)
            if found is not None:
                return Answer(YES, True, found)
            if self.timed_out:
                break  # more segments would only take longer
        found = self.periodic()
        if found is not None:
            return Answer(YES, True, found)
        quick = self.limits.quick()
        verdict, core = refute(self.formulas, self.system, set(self.names), quick)
        if verdict == "unsat":
            return Answer(NO, True, core=core)
        for k in late if not self.timed_out else ():
            found = self.search(k)
            if found is not None:
                return Answer(YES, True, found)
        if verdict == "limit" and quick != self.limits:
            verdict, core = refute(self.formulas, self.system, set(self.names), self.limits)
            if verdict == "unsat":
                return Answer(NO, True, core=core)
        if verdict == "limit":
            self.timed_out = True
        if self.timed_out:
            note = "the solver's limit was reached before an answer"
        else:
            note = (
                f"no witness with at most {counted(max(sizes) - 1, 'change')}, "
                "and no proof that none exists"
            )
        if self.replay_failures:
            failed = counted(self.replay_failures, "candidate trace")
            note += f" ({failed} did not replay: a bug, reported)"
        return Answer(UNKNOWN, False, note=note, timed_out=self.timed_out)

    def search(self, segments: int) -> Witness | None:
        trace = _encoding(segments, tuple(self.names), self.free_time)
        solver = z3.Solver()
        self.limits.configure(solver)
        assert_all(solver, trace.structure)
        assert_all(solver, self.system_constraints(trace))
        at = (-1, Fraction(0)) if self.free_time else (0, Fraction(0))
        trace.deadline = time.monotonic() + self.limits.timeout
        try:
            for f in self.formulas:
                value = trace.value(f, at)
                solver.add(value if not isinstance(value, bool) else z3.BoolVal(value))
        except EncodingTimeout:
            self.timed_out = True
            return None
        finally:
            trace.deadline = float("inf")
        assert_all(solver, trace.definitions)
        checkpoint()
        result = solver.check()
        if result == z3.unknown:
            self.timed_out = True
            return None
        if result == z3.unsat:
            return None
        times, states, at_time = trace.read(solver.model())
        witness = self.replayed(times, states, at_time)
        if witness is None:
            self.replay_failures += 1
        return witness

    def constant(self) -> tuple[Witness | None, bool]:
        """The one-segment search without the solver: the system's constant traces
        over the question's names, judged by the runtime's monitor at time 0, so a
        yes is exact. Most questions a check asks have such a witness, and z3 took
        5 ms to find one where the monitor takes a fraction of that. A transducer's
        states that no formula mentions look alike to the formulas: one of them is
        tried. Also says whether every constant trace was tried at every time the
        question allows (none looks back: a constant trace reads the same from
        any time on), so the solver's one-segment search can find none."""
        machines = self.system.relevant(self.mentioned)
        choices: list[list[str]] = []
        for machine in machines:
            if machine.initial is not None:
                choices.append([machine.initial])
                continue
            others = [s for s in machine.states if s not in self.mentioned][:1]
            choices.append([s for s in machine.states if s in self.mentioned] + others)
        owned = {s for m in machines for s in m.states}
        free = [n for n in self.names if n not in owned and n not in self.system.never]
        subsets = itertools.chain.from_iterable(
            itertools.combinations(free, size) for size in range(len(free) + 1)
        )
        candidates = (
            frozenset((*held, *states))
            for held in subsets
            for states in itertools.product(*choices)
        )
        for state in itertools.islice(candidates, CONSTANT_CANDIDATES):
            witness = self.witness([Fraction(0)], [state], Fraction(0))
            if self.monitored(witness):
                return witness, True
        count = 2 ** len(free) * math.prod(map(len, choices))
        return None, count <= CONSTANT_CANDIDATES and not self.looks_back

    def periodic(self) -> Witness | None:
        """Traces where each proposition is constant or alternates with a half
        period drawn from the formulas' bounds: the witnesses that need more
        changes than the segment searches allow (`always[<b](eventually[<=1] a and
        eventually[<=1] not a)` needs about 2b), judged by the runtime's monitor, so
        a yes is still exact. Only for a few propositions that no transducer constrains, and
        within a budget of segments: a question without such a witness loses
        little."""
        if len(self.names) > PERIODIC_NAMES or self.system.relevant(set(self.names)):
            return None
        end = self.horizon + 1
        budget = PERIODIC_BUDGET
        # whether a proposition holds on the even and on the odd segments
        held = {
            "off": (False, False),
            "on": (True, True),
            "even": (True, False),
            "odd": (False, True),
        }
        patterns = [
            p
            for p in itertools.product(held, repeat=len(self.names))
            if "even" in p or "odd" in p  # constant traces: the one-segment search
        ]
        for half in _half_periods(self.formulas):
            count = int(end / half) + 1
            if count * len(patterns) > budget:
                continue
            budget -= count * len(patterns)
            times = [half * i for i in range(count)]
            for pattern in patterns:
                states = [
                    frozenset(
                        n for n, kind in zip(self.names, pattern, strict=True) if held[kind][i % 2]
                    )
                    for i in range(count)
                ]
                witness = self.witness(times, states, Fraction(0))
                if self.monitored(witness):
                    return witness
        return None

    def monitored(self, witness: Witness) -> bool:
        """Whether the runtime's monitor (exact, as the reference evaluator is, and
        linear in the trace where the reference is not) says every formula holds
        on the witness, a trace of the system."""
        if self.system.violation(witness.times, witness.states, set(self.names)) is not None:
            return False
        for formula in self.formulas:
            monitor = Monitor(formula)
            # whole times as ints: the same numbers, and the monitor's arithmetic
            # on them several times faster than on Fractions
            monitor.feed(zip(map(plain, witness.times), witness.states, strict=True))
            monitor.end(plain(witness.end))
            # read from the verdicts, not the monitor's signals: those keep only
            # the history a live monitor needs (a horizon or two before the end)
            if verdict_at(monitor.verdicts(), witness.at) != "true":
                return False
        return True

    def system_constraints(self, trace: BoundedTrace) -> list[Any]:
        key = repr((self.system.key(), self.names))
        if key not in trace.derived:
            trace.derived[key] = _system_constraints(self.system, trace, set(self.names))
        return trace.derived[key]

    def replayed(
        self, times: list[Fraction], states: list[frozenset[str]], at: Fraction
    ) -> Witness | None:
        """The candidate, merged and with round times where they still replay; None
        if it does not replay at all."""
        kept_times, kept_states = [times[0]], [states[0]]
        for t, s in zip(times[1:], states[1:], strict=True):
            if s != kept_states[-1]:
                kept_times.append(t)
                kept_states.append(s)
        for grid in (1, 2, 4, 10, 100, 1000, 10**6, None):
            candidate = _rounded(kept_times, at, grid)
            if candidate is None:
                continue
            witness = self.witness(candidate[0], kept_states, candidate[1])
            if self.replays(witness):
                # Only a witness of one formula is shown to a reader.
                return self.simplified(witness) if len(self.formulas) == 1 else witness
        return None

    def simplified(self, witness: Witness, budget: int = 200) -> Witness:
        """Fewer propositions held, where the witness still replays: a reader should
        see what matters, not what the solver happened to choose."""
        states = list(witness.states)
        for index in range(len(states)):
            for name in sorted(states[index]):
                if budget == 0:
                    break
                budget -= 1
                trial = [*states[:index], states[index] - {name}, *states[index + 1 :]]
                candidate = Witness(
                    witness.times, tuple(trial), witness.at, witness.end, witness.names
                )
                if self.replays(candidate):
                    states = trial
        times, kept = [witness.times[0]], [states[0]]
        for t, state in zip(witness.times[1:], states[1:], strict=True):
            if state != kept[-1]:
                times.append(t)
                kept.append(state)
        return self.witness(times, kept, witness.at)

    def witness(self, times: list[Fraction], states: list[frozenset[str]], at: Fraction) -> Witness:
        end = max(at, times[-1]) + self.horizon + 1
        return Witness(tuple(times), tuple(states), at, end, tuple(self.names))

    def replays(self, witness: Witness) -> bool:
        """Whether the runtime's monitor confirms the solver's witness (the reference
        evaluator said the same, tested everywhere, but its time at a value grows
        with the nesting of temporal operators: a witness of ten nested
        `eventually` replayed for most of a check's time)."""
        return self.monitored(witness)


def _system_constraints(system: System, trace: BoundedTrace, names: set[str]) -> list[Any]:
    """Each relevant transducer in exactly one state per segment, the initial one
    first, a new state only by a transition into it; exclusive and impossible
    events."""
    facts: list[Any] = []
    holds = trace.holds
    for machine in system.relevant(names):
        for i in range(trace.k):
            facts.append(z3.PbEq([(holds[i][s], 1) for s in machine.states], 1))
        if machine.initial is not None:
            facts.append(holds[0][machine.initial])
        sources = {s: [a for a, b in machine.moves if b == s] for s in machine.states}
        for i in range(trace.k - 1):
            for state in machine.states:
                came = [holds[i][state], *(holds[i][a] for a in sources[state])]
                facts.append(implication(holds[i + 1][state], disjunction(came)))
    for a, b in system.exclusive:
        if a in names and b in names:
            facts.extend(negation(conjunction([holds[i][a], holds[i][b]])) for i in range(trace.k))
    for name in system.never:
        if name in names:
            facts.extend(negation(holds[i][name]) for i in range(trace.k))
    return facts


def _half_periods(formulas: Sequence[Any]) -> list[Fraction]:
    """Half periods for `periodic`: the halves and quarters of the formulas' bounds,
    longest first (fewest segments), at most PERIODIC_PERIODS of them."""
    bounds: set[Fraction] = set()
    stack = list(formulas)
    while stack:
        node = stack.pop()
        if node[0] in ("until", "since") and node[2] is not None and node[2] > 0:
            bounds.add(Fraction(node[2]))
        elif node[0] == "dur" and node[1] > 0:
            bounds.add(Fraction(node[1]))
        stack.extend(c for c in node[1:] if isinstance(c, tuple))
    halves = {b / d for b in bounds for d in (2, 4)}
    return sorted(halves, reverse=True)[:PERIODIC_PERIODS]


_ENCODINGS: dict[tuple[int, tuple[str, ...], bool], BoundedTrace] = {}


def _encoding(segments: int, names: tuple[str, ...], free_time: bool) -> BoundedTrace:
    """The symbolic trace for these sizes, shared between questions: a formula asked
    about again (with others, negated) is encoded once. The 32 last used are kept."""
    key = (segments, names, free_time)
    encoding = _ENCODINGS.pop(key, None)  # re-inserted last: least recently used first out
    if encoding is None:
        if len(_ENCODINGS) >= 32:
            _ENCODINGS.pop(next(iter(_ENCODINGS)))
        encoding = BoundedTrace(segments, list(names), free_time)
    _ENCODINGS[key] = encoding
    return encoding


def _rounded(
    times: list[Fraction], at: Fraction, grid: int | None
) -> tuple[list[Fraction], Fraction] | None:
    if grid is None:
        return times, at
    rounded = [Fraction(round(t * grid), grid) for t in times]
    if any(b <= a for a, b in itertools.pairwise(rounded)):
        return None
    return rounded, Fraction(round(at * grid), grid)
