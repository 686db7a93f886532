"""What a spec says about its traces, for the satisfiability questions.

The propositions of a property are transducer states and boolean events. A trace
of the system respects its transducers: a transducer is in exactly one of its
states at any time, and changes state only along one of its transitions (where it
starts is given when known: `initial`). Events whose conditions can never hold together never hold
together; an event whose condition can never hold never holds. Only facts that
are certain go here: what is left out only makes the questions more permissive.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction

from rmvdsl.runtime.wording import counted

RESTRICTIONS_KEPT = 4096  # cuts of one system remembered


@dataclass(frozen=True)
class Machine:
    name: str
    states: tuple[str, ...]
    initial: str | None
    moves: frozenset[tuple[str, str]]  # (from, to), from != to


@dataclass(frozen=True)
class System:
    transducers: tuple[Machine, ...] = ()
    exclusive: frozenset[tuple[str, str]] = field(default_factory=frozenset)
    never: frozenset[str] = field(default_factory=frozenset)

    def restricted(self, names: set[str]) -> System:
        """What constrains traces over these propositions: the rest is left out, so
        that a question's cache key does not change with unrelated declarations.
        Costs what the propositions touch, not the size of the system; made once
        for each set of names (every question on a property cuts the system the
        same way, and its key is computed once a cut)."""
        key = frozenset(names)
        found = self._restrictions.get(key)
        if found is None:
            if len(self._restrictions) >= RESTRICTIONS_KEPT:
                self._restrictions.clear()
            found = self._restrictions[key] = self._restricted(key)
        return found

    @functools.cached_property
    def _restrictions(self) -> dict[frozenset[str], System]:
        return {}

    def _restricted(self, names: frozenset[str]) -> System:
        machines = self.relevant(names)
        every = set(names).union(*(m.states for m in machines))
        pairs = (p for n in every for p in self._exclusive_of.get(n, ()))
        return System(
            machines,
            frozenset(p for p in pairs if p[1] in every),
            frozenset(every & self.never),
        )

    @functools.cached_property
    def _machine_of(self) -> dict[str, int]:
        """The index of the transducer owning each state."""
        return {s: i for i, m in enumerate(self.transducers) for s in m.states}

    @functools.cached_property
    def _exclusive_of(self) -> dict[str, list[tuple[str, str]]]:
        out: dict[str, list[tuple[str, str]]] = {}
        for pair in self.exclusive:
            out.setdefault(pair[0], []).append(pair)
        return out

    @functools.cached_property
    def _key(self) -> str:
        return repr(
            (
                sorted((m.name, m.states, m.initial, sorted(m.moves)) for m in self.transducers),
                sorted(self.exclusive),
                sorted(self.never),
            )
        )

    def key(self) -> str:
        return self._key

    def from_any_state(self) -> System:
        """The system with its transducers starting in any of their states: the
        traces it has from any time on, as a monitor started then sees them."""
        machines = tuple(Machine(m.name, m.states, None, m.moves) for m in self.transducers)
        return System(machines, self.exclusive, self.never)

    def relevant(self, names: set[str] | frozenset[str]) -> tuple[Machine, ...]:
        """The transducers owning any of these names, in their order."""
        owners = self._machine_of
        return tuple(self.transducers[i] for i in sorted({owners[n] for n in names if n in owners}))

    def names(self, names: set[str]) -> set[str]:
        """The propositions a trace over `names` must also give: every state of a
        transducer any of whose states is mentioned."""
        out = set(names)
        for machine in self.relevant(names):
            out.update(machine.states)
        return out

    def violation(
        self, times: Sequence[Fraction], states: Sequence[frozenset[str]], names: set[str]
    ) -> str | None:
        """Why this trace over the propositions `names` is not one of the system's
        (None if it is)."""
        for machine in self.relevant(names):
            current = [[s for s in machine.states if s in state] for state in states]
            for time, now in zip(times, current, strict=True):
                if len(now) != 1:
                    return f"{machine.name} is in {counted(len(now), 'state')} at {time}"
            if machine.initial is not None and current[0] != [machine.initial]:
                return f"{machine.name} does not start in {machine.initial}"
            for before, after in itertools.pairwise(current):
                if before != after and (before[0], after[0]) not in machine.moves:
                    return f"{machine.name} has no transition {before[0]} -> {after[0]}"
        for a, b in self.exclusive:
            if any(a in s and b in s for s in states):
                return f"{a} and {b} hold together"
        for name in self.never:
            if any(name in s for s in states):
                return f"{name} holds"
        return None
