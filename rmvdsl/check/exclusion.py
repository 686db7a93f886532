"""The boolean events that can never hold, and the pairs that can never hold together.

Only events whose conditions read a common variable can exclude each other (two
satisfiable conditions over disjoint variables hold together). Asking z3 once per
event and once per such pair was quadratic: 2,000 events over one variable (`x > 0`,
`x > 1`, ...) were two million questions, hours of checking. Here each group of
events linked by the variables they read is one solver, each event's condition
behind a literal of its own, and a model clears everything it satisfies at once:
every event it makes hold is satisfiable, and every pair of them holds together.
The whole group is asked first; then each event not yet joined, with its partners
not yet decided; a pair that no model joins is asked alone, and only its "unsat"
makes it exclusive (an "unknown", a time limit, makes no claim, as before). The
questions grow with what is found never or exclusive, not with the pairs there are;
the answers are those the single questions gave, cached per group.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import z3

from rmvdsl.check.conditions import Conditions
from rmvdsl.check.solving import condition_solver, names_in
from rmvdsl.logic.terms import Z3_VERSION
from rmvdsl.util.cache import default_cache, digest
from rmvdsl.util.cancel import checkpoint

Pair = tuple[str, str]


def event_relations(events: list[str], conditions: Conditions) -> tuple[set[str], set[Pair]]:
    """The events that never hold, and the pairs (a, b) of the others, a before b in
    `events`, that share a variable and never hold together."""
    order = {event: index for index, event in enumerate(events)}
    terms = {event: conditions.of_event(event) for event in events}
    reads = {event: conditions.names_of(terms[event]) for event in events}
    readers: dict[str, set[str]] = {}
    for event in events:
        for name in reads[event]:
            readers.setdefault(name, set()).add(event)
    never: set[str] = set()
    exclusive: set[Pair] = set()
    for group in _linked(events, order, reads, readers):
        impossible, pairs = _answers(group, terms, reads, readers, conditions)
        never.update(impossible)
        exclusive.update((a, b) if order[a] < order[b] else (b, a) for a, b in pairs)
    return never, exclusive


def _linked(
    events: list[str],
    order: dict[str, int],
    reads: dict[str, set[str]],
    readers: dict[str, set[str]],
) -> Iterator[list[str]]:
    """The events in groups linked by the variables they read, each in order."""
    seen: set[str] = set()
    for first in events:
        if first in seen:
            continue
        seen.add(first)
        group, stack = [], [first]
        while stack:
            event = stack.pop()
            group.append(event)
            for name in reads[event]:
                fresh = readers[name] - seen
                seen |= fresh
                stack.extend(fresh)
        yield sorted(group, key=order.__getitem__)


def _answers(
    group: list[str],
    terms: dict[str, Any],
    reads: dict[str, set[str]],
    readers: dict[str, set[str]],
    conditions: Conditions,
) -> tuple[list[str], list[Pair]]:
    """A group's events that never hold and its exclusive pairs, from the cache when
    the group's conditions were asked before."""
    used = names_in([terms[event] for event in group])
    ranged = sorted(used & conditions.domains.keys())
    domains = [c for name in ranged for c in conditions.domains[name]]
    key = digest(
        "event relations",
        "1",
        Z3_VERSION,
        [(event, terms[event].sexpr()) for event in group],
        [c.sexpr() for c in domains],
    )
    cache = default_cache()
    cached = cache.get(key)
    if cached is not None and isinstance(cached.get("pairs"), list):
        return list(cached["never"]), [(a, b) for a, b in cached["pairs"]]
    solver = _Group(group, terms, domains, reads, readers)
    never, pairs = solver.never(), solver.exclusive()
    if solver.complete:  # a question cut short by the time limit is not an answer to keep
        cache.put(key, {"never": never, "pairs": [list(pair) for pair in pairs]})
    return never, pairs


class _Group:
    """One solver over a group's conditions, each behind its literal."""

    def __init__(
        self,
        group: list[str],
        terms: dict[str, Any],
        domains: list[Any],
        reads: dict[str, set[str]],
        readers: dict[str, set[str]],
    ) -> None:
        # A context of its own: z3's checks slow with every term alive in a context
        # (rmvdsl.check.solving), and the group's terms are all this one holds.
        context = z3.Context()
        domains = [term.translate(context) for term in domains]
        self.conditions = {event: terms[event].translate(context) for event in group}
        self.solver = condition_solver([*domains, *self.conditions.values()], context)
        self.solver.add(*domains)
        self.group, self.reads, self.readers = group, reads, readers
        self.literals = {event: z3.Bool(f"holds {event}", context) for event in group}
        self.event_of = {literal.get_id(): event for event, literal in self.literals.items()}
        for event in group:
            self.solver.add(z3.Implies(self.literals[event], self.conditions[event]))
        self.possible: set[str] = set()  # events some model made hold
        self.impossible: set[str] = set()
        self.together: dict[str, list[set[str]]] = {event: [] for event in group}  # models
        self.decided: dict[str, set[str]] = {event: set() for event in group}
        self.complete = True

    def never(self) -> list[str]:
        """The events no value makes hold: the whole group asked at once first."""
        self._ask(self.group)
        for event in self.group:
            if event not in self.possible:
                checkpoint()  # the editor may stop here (rmvdsl.util.cancel)
                answer = self._ask([event])
                if answer == z3.unsat:
                    self.impossible.add(event)
                elif answer == z3.unknown:
                    self.complete = False
        return [event for event in self.group if event in self.impossible]

    def exclusive(self) -> list[Pair]:
        """The pairs of possible events sharing a variable that never hold together."""
        pairs: list[Pair] = []
        for event in self.group:
            if event in self.impossible:
                continue
            checkpoint()
            todo = self._undecided(event)
            while todo:
                answer = self._ask([event, *todo])
                if answer == z3.sat:
                    break
                # "no" (or no answer in time): a partner is asked alone with it
                other = self._in_core(todo) if answer == z3.unsat else todo[0]
                alone = self._ask([event, other])
                if alone == z3.unsat:
                    pairs.append((event, other))
                elif alone == z3.unknown:  # no claim, as before
                    self.complete = False
                self.decided[event].add(other)
                self.decided[other].add(event)
                todo = self._undecided(event)
        return pairs

    def _ask(self, events: list[str]) -> Any:
        """Can these events hold at once? A model found is read for every event."""
        answer = self.solver.check(*(self.literals[event] for event in events))
        if answer == z3.sat:
            model = self.solver.model()
            holding = {
                event
                for event, condition in self.conditions.items()
                if z3.is_true(model.eval(condition, model_completion=True))
            }
            holding.update(events)  # made to hold, whatever eval printed
            self.possible |= holding
            for event in holding:
                self.together[event].append(holding)
        return answer

    def _undecided(self, event: str) -> list[str]:
        """The possible partners of `event` no model has joined it with and not asked
        with it alone, in the group's order (the same questions on every run)."""
        partners: set[str] = set()
        for name in self.reads[event]:
            partners |= self.readers[name]
        partners.discard(event)
        left = partners.difference(self.impossible, self.decided[event], *self.together[event])
        return [u for u in self.group if u in left]

    def _in_core(self, todo: list[str]) -> str:
        """A partner the solver's reason for "no" names (else the first undecided)."""
        named = {self.event_of.get(literal.get_id()) for literal in self.solver.unsat_core()}
        return next((u for u in todo if u in named), todo[0])
