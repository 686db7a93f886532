"""Questions up to the names of their propositions (docs/verification.md).

Whether formulas can hold on a system's traces does not depend on what its states
and events are called: rename the propositions one to one, in formulas and system
alike, and the answer is the same, its witness renamed. A spec says the same thing
of many parts (a transducer per robot, a property per transducer), and an editor's
user renames: each question is therefore asked, and kept in the cache, in one
naming of its own, its canonical form. Its propositions are named `p0`, `p1`, ...
in the order the formulas first mention them, then the remaining states of each
transducer they touch in its declared order; transducers are `m0`, `m1`, ... Two
questions that differ only in names have one canonical form, so one answer.

The solver only ever sees canonical questions: an answer is a function of the
question, whichever of its namings was asked first.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from rmvdsl.logic.answers import Answer, Witness
from rmvdsl.logic.limits import Limits
from rmvdsl.logic.system import Machine, System
from rmvdsl.logic.terms import Z3_VERSION
from rmvdsl.runtime.nesting import bottom_up
from rmvdsl.runtime.rmtld3 import facts
from rmvdsl.util.bounded import Bounded
from rmvdsl.util.cache import digest

# Bump when an encoding changes: cached answers carry it in their key.
ENCODING_VERSION = "4"  # 3: canonical naming; 4: constant witnesses first
CANONICAL_KEPT = 4096  # questions whose canonical form is remembered (a few KB each)


@dataclass(frozen=True)
class Canonical:
    """A question in its canonical naming, with the way back to the caller's names."""

    key: str
    formulas: tuple[Any, ...]
    system: System
    restricted: System  # the caller's system, cut to what the formulas mention
    names: dict[str, str] = field(repr=False)  # the caller's name -> canonical

    def real(self, answer: Answer) -> Answer:
        """A canonical answer in the caller's names."""
        if answer.witness is None:
            return answer
        back = {canonical: name for name, canonical in self.names.items()}
        return _with_witness(answer, _renamed_witness(answer.witness, back))

    def canonical(self, witness: Witness) -> Witness:
        """A trace in the caller's names, in the canonical ones (what the question
        does not mention left out)."""
        return _renamed_witness(witness, self.names)


_KEPT: Bounded[tuple[Any, ...], Canonical] = Bounded(CANONICAL_KEPT)


def keep_at_least(count: int) -> None:
    """Remember the canonical forms of twice this many questions: a check keys
    each question when it asks ahead and again when it reads the answer, and a
    bound below a check's questions made it key every one twice (a 159,000-line
    spec's cached check took twice as long)."""
    _KEPT.fit(count)


def canonical(formulas: Sequence[Any], system: System | None, limits: Limits) -> Canonical:
    """The canonical form of the question "can `formulas` hold together on the
    traces of `system`", and its cache key."""
    restricted = cut_system(formulas, system)
    memo = (tuple(formulas), restricted.key(), limits.key())
    found = _KEPT.get(memo)
    if found is None:
        names, machines = _naming(formulas, restricted)
        renamed = tuple(_renamed_formula(f, names) for f in formulas)
        renamed_system = _renamed_system(restricted, names, machines)
        key = digest(ENCODING_VERSION, Z3_VERSION, list(renamed), renamed_system.key(),
                     limits.key())  # fmt: skip
        found = Canonical(key, renamed, renamed_system, restricted, names)
        _KEPT.put(memo, found)
    return found


def cut_system(formulas: Sequence[Any], system: System | None) -> System:
    """The part of the system that constrains what the formulas mention."""
    mentioned = {name for f in formulas for name in facts(f).propositions}
    return (system or System()).restricted(mentioned)


def _naming(formulas: Sequence[Any], system: System) -> tuple[dict[str, str], list[Machine]]:
    """Each proposition's canonical name: by first mention in the formulas, then
    the other states of the transducers, in the order of their first mention; and
    the transducers in that order (the i-th is `m<i>`). A cut system holds no
    other name: its exclusive and impossible events are among these."""
    order: dict[str, None] = {}
    for formula in formulas:
        order.update(dict.fromkeys(facts(formula).propositions))
    first = {name: index for index, name in enumerate(order)}
    machines = sorted(
        system.transducers, key=lambda m: min(first.get(s, len(first)) for s in m.states)
    )
    for machine in machines:
        order.update(dict.fromkeys(machine.states))
    return {name: f"p{index}" for index, name in enumerate(order)}, machines


def _renamed_system(system: System, names: dict[str, str], machines: list[Machine]) -> System:
    renamed = tuple(
        Machine(
            f"m{index}",
            tuple(names[s] for s in m.states),
            None if m.initial is None else names[m.initial],
            frozenset((names[a], names[b]) for a, b in m.moves),
        )
        for index, m in enumerate(machines)
    )
    return System(
        renamed,
        frozenset((names[a], names[b]) for a, b in system.exclusive),
        frozenset(names[n] for n in system.never),
    )


def _renamed_formula(formula: Any, names: dict[str, str]) -> Any:
    """The formula with its propositions renamed: by recursion (twice as fast for
    the shallow formulas most are), else, past the stack's limit, by a loop
    (formulas can nest 100,000 levels), where a subformula shared is renamed once."""
    try:
        return _renamed_shallow(formula, names, {})
    except RecursionError:
        pass

    def rebuild(node: Any, fields: list[Any]) -> Any:
        if node[0] == "prop":
            return _rebuilt(node, (node[0], names[node[1]]))
        return _rebuilt(node, (node[0], *fields))

    return bottom_up(formula, rebuild)


def _renamed_shallow(node: Any, names: dict[str, str], done: dict[int, Any]) -> Any:
    """`_renamed_formula` by recursion; `done`: the subformulas renamed so far, by
    identity (`a <-> b` shares its sides: a chain of them is a graph whose paths
    grow exponentially)."""
    found = done.get(id(node))
    if found is None:
        if node[0] == "prop":
            found = _rebuilt(node, (node[0], names[node[1]]))
        else:
            items = [_renamed_shallow(c, names, done) if isinstance(c, tuple) else c for c in node]
            found = _rebuilt(node, items)
        done[id(node)] = found
    return found


def _rebuilt(node: tuple[Any, ...], items: Sequence[Any]) -> tuple[Any, ...]:
    """A node of the same class (the runtime's named tuples, or the checker's plain
    `("not", f)`) with these items."""
    make = getattr(node, "_make", None)
    return make(items) if make is not None else tuple(items)


def _renamed_witness(witness: Witness, names: dict[str, str]) -> Witness:
    return Witness(
        witness.times,
        tuple(frozenset(names[n] for n in state if n in names) for state in witness.states),
        witness.at,
        witness.end,
        tuple(sorted(names[n] for n in witness.names if n in names)),  # as a search names them
    )


def _with_witness(answer: Answer, witness: Witness) -> Answer:
    return Answer(answer.value, answer.exact, witness, answer.core, answer.note, answer.timed_out)
