"""Which properties of a group the others imply (RMV515), in pure logic.

Latest first, and a redundant property no longer counts for the others: of two
equivalent properties the later one is reported, once. A trace already at hand
where the others hold and the property fails shows it is not implied, with no
solver call. The checker (rmvdsl.check.properties) turns the answer into notes;
the parallel workers run the same function to answer its questions ahead.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from typing import Any

from rmvdsl.logic.answers import NO, Witness
from rmvdsl.logic.reference import FALSE, TRUE, Reference, Trace
from rmvdsl.logic.sat import Limits, question_key, satisfiable
from rmvdsl.logic.system import System
from rmvdsl.runtime.rmtld3 import facts
from rmvdsl.util.cache import Cache, digest


def implied(
    names: Sequence[str],
    formulas: Sequence[Any],
    system: System,
    limits: Limits,
    cache: Cache,
    known: Sequence[Witness] = (),
) -> list[tuple[str, list[str]]]:
    """Each redundant property with the ones that imply it (a smallest set the
    refutation found, else all the others kept), latest first. The whole answer is
    cached by the group's formulas (by position: renaming a property keeps it), so
    re-checking asks neither the solver nor the known traces."""
    key = group_key(formulas, system, limits)
    cached = cache.get(key)
    if cached is not None and isinstance(cached.get("implied"), list):
        return [(names[i], [names[j] for j in by]) for i, by in cached["implied"]]
    found, complete = _implied(list(formulas), system, limits, cache, known)
    if complete:  # no answer cut short by a time limit
        cache.put(key, {"implied": [[i, by] for i, by in found]})
    return [(names[i], [names[j] for j in by]) for i, by in found]


def group_key(formulas: Sequence[Any], system: System, limits: Limits) -> str:
    """The cache key of a group's redundancy."""
    return digest("implied", question_key(formulas, system, limits)[0])


def _implied(
    formulas: list[Any], system: System, limits: Limits, cache: Cache, known: Sequence[Witness]
) -> tuple[list[tuple[int, list[int]]], bool]:
    traces = _KnownTraces(formulas, system, list(known))
    found: list[tuple[int, list[int]]] = []
    kept = list(range(len(formulas)))
    complete = True
    for index in reversed(range(len(formulas))):
        others = [i for i in kept if i != index]
        if traces.refute(formulas[index], [formulas[i] for i in others]):
            continue
        question = [formulas[i] for i in others] + [("not", formulas[index])]
        answer = satisfiable(question, system, limits, cache)
        complete = complete and not answer.timed_out
        if answer.witness is not None:
            traces.add(answer.witness)
        if answer.value != NO:
            continue
        kept.remove(index)
        found.append((index, [others[i] for i in answer.core if i < len(others)] or others))
    return found, complete


class _KnownTraces:
    """Traces of the system over the group's propositions, each with the reference
    evaluator on it (values computed once a trace)."""

    def __init__(self, formulas: Sequence[Any], system: System, known: list[Witness]) -> None:
        self.system = system
        self.names = {n for f in formulas for n in facts(f).propositions}
        self.horizon = max((facts(f).future for f in formulas), default=Fraction(0))
        self.references: list[tuple[Reference, Fraction]] = []  # and the time to ask at
        for witness in known:
            self.add(witness)

    def add(self, witness: Witness) -> None:
        """Keep a trace that is one of the system's for all the propositions (its
        last state held long enough for every property)."""
        if self.system.violation(witness.times, witness.states, self.names) is not None:
            return
        end = max(witness.end, witness.at + self.horizon + 1)
        reference = Reference(Trace(list(witness.times), list(witness.states), end))
        self.references.append((reference, witness.at))

    def refute(self, formula: Any, others: list[Any]) -> bool:
        """A known trace where the others hold and `formula` fails."""
        for reference, at in self.references:
            if reference.value(formula, at) != FALSE:
                continue
            if all(reference.value(f, at) == TRUE for f in others):
                return True
        return False
