"""The refutation: an over-approximation of RMTLD3 in first-order logic, for z3.

Propositions become uninterpreted predicates over the reals (any function at all,
not only traces with finitely many changes); each temporal subformula becomes a
predicate with its definition as quantified axioms, in the direction its polarity
needs (Plaisted-Greenbaum: a subformula that only occurs positively needs only
"holds implies its definition"); durations become functions bounded by their
window, with only facts true of every trace (0 <= duration[T](phi) <= T, and
duration[T](phi) + duration[T](not phi) = T).

Every trace is a model of these axioms, so when z3 proves them unsatisfiable no
trace satisfies the formulas: that answer is exact. A model of the axioms proves
nothing (it may be no trace at all), so "sat" here is never used.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from fractions import Fraction
from typing import TYPE_CHECKING, Any

import z3

from rmvdsl.logic.system import System
from rmvdsl.runtime.rmtld3 import facts
from rmvdsl.util.cancel import checkpoint

if TYPE_CHECKING:
    from rmvdsl.logic.limits import Limits


class Refuter:
    def __init__(self, system: System) -> None:
        self.system = system
        self.predicates: dict[str, Any] = {}
        self.temporal: dict[Any, Any] = {}
        self.done: set[tuple[Any, int]] = set()
        self.durations: dict[tuple[Fraction, Any], Any] = {}
        self.axioms: list[Any] = []
        self._fresh = itertools.count()

    def prop(self, name: str) -> Any:
        if name not in self.predicates:
            self.predicates[name] = z3.Function(f"p_{name}", z3.RealSort(), z3.BoolSort())
        return self.predicates[name]

    def variable(self, stem: str) -> Any:
        return z3.Real(f"{stem}{next(self._fresh)}")

    def encode(self, f: Any, polarity: int, at: Any) -> Any:
        kind = f[0]
        if kind == "prop":
            return self.prop(f[1])(at)
        if kind == "const":
            return z3.BoolVal(bool(f[1]))
        if kind == "not":
            return z3.Not(self.encode(f[1], -polarity, at))
        if kind in ("and", "or"):
            parts = [self.encode(f[1], polarity, at), self.encode(f[2], polarity, at)]
            return z3.And(*parts) if kind == "and" else z3.Or(*parts)
        if kind in ("until", "since"):
            return self.temporal_node(f, polarity)(at)
        _, op, left, right = f
        x, y = self.term(left, at), self.term(right, at)
        return {
            "<": x < y,
            "<=": x <= y,
            ">": x > y,
            ">=": x >= y,
            "==": x == y,
            "!=": x != y,
        }[op]

    def temporal_node(self, f: Any, polarity: int) -> Any:
        if f not in self.temporal:
            name = f"{f[0]}{len(self.temporal)}"
            self.temporal[f] = z3.Function(name, z3.RealSort(), z3.BoolSort())
        predicate = self.temporal[f]
        if (f, polarity) not in self.done:
            self.done.add((f, polarity))
            self.define(f, predicate, polarity)
        return predicate

    def define(self, f: Any, predicate: Any, polarity: int) -> None:
        kind, op, bound, phi, psi = f
        at, witness, between = self.variable("e"), self.variable("w"), self.variable("u")
        if bound is None:  # a `since` with no bound: any witness from time 0 on
            window = z3.And(witness >= 0, witness <= at)
            span = z3.And(witness < between, between <= at)
        elif kind == "until":
            bound = z3.RealVal(str(Fraction(bound)))
            window = {
                "<": z3.And(at <= witness, witness < at + bound),
                "<=": z3.And(at <= witness, witness <= at + bound),
                "=": witness == at + bound,
            }[op]
            span = z3.And(at <= between, between < witness)
        else:
            bound = z3.RealVal(str(Fraction(bound)))
            window = z3.And(
                witness >= 0,
                {
                    "<": z3.And(at - bound < witness, witness <= at),
                    "<=": z3.And(at - bound <= witness, witness <= at),
                    "=": witness == at - bound,
                }[op],
            )
            span = z3.And(witness < between, between <= at)
        goal = self.encode(psi, polarity, witness)
        if phi != ("const", True):
            goal = z3.And(
                goal, z3.ForAll([between], z3.Implies(span, self.encode(phi, polarity, between)))
            )
        body = z3.And(window, goal)
        if polarity > 0:
            self.axioms.append(
                z3.ForAll([at], z3.Implies(predicate(at), z3.Exists([witness], body)))
            )
        else:
            self.axioms.append(z3.ForAll([at, witness], z3.Implies(body, predicate(at))))

    def term(self, term: Any, at: Any) -> Any:
        kind = term[0]
        if kind == "num":
            return z3.RealVal(str(Fraction(term[1])))
        if kind == "dur":
            return self.duration(Fraction(term[1]), term[2])(at)
        left, right = self.term(term[1], at), self.term(term[2], at)
        return {"add": left + right, "sub": left - right, "mul": left * right}[kind]

    def duration(self, window: Fraction, body: Any) -> Any:
        key = (window, body)
        if key in self.durations:
            return self.durations[key]
        function = z3.Function(f"dur{len(self.durations)}", z3.RealSort(), z3.RealSort())
        self.durations[key] = function
        t = self.variable("d")
        length = z3.RealVal(str(window))
        if body == ("const", True):
            self.axioms.append(z3.ForAll([t], function(t) == length))
        elif body == ("const", False):
            self.axioms.append(z3.ForAll([t], function(t) == 0))
        else:
            self.axioms.append(z3.ForAll([t], z3.And(function(t) >= 0, function(t) <= length)))
        negated = body[1] if body[0] == "not" else ("not", body)
        other = self.durations.get((window, negated))
        if other is not None:
            self.axioms.append(z3.ForAll([t], function(t) + other(t) == length))
        return function

    def pinned_durations(self) -> list[Any]:
        """What bounded `always` and `eventually` fix of a duration from the same
        start: `always[<b] phi` makes duration[T](phi) at least min(b, T) (all of T
        when b >= T), and no `eventually[<b] phi` makes it at most T - min(b, T).
        True of every trace, so answers stay exact."""
        facts: list[Any] = []
        t = self.variable("q")
        for node, predicate in self.temporal.items():
            kind, op, bound, left, psi = node
            if kind != "until" or left != ("const", True) or op == "=":
                continue
            for (window, body), duration in self.durations.items():
                covered = z3.RealVal(str(min(Fraction(bound), window)))
                length = z3.RealVal(str(window))
                if _plain(psi) == _plain(body):  # phi never holds in [t, t + b)
                    pinned = duration(t) <= length - covered
                elif _plain(psi) == _plain(("not", body)):  # phi holds all through it
                    pinned = duration(t) >= covered
                else:
                    continue
                facts.append(z3.ForAll([t], z3.Implies(z3.Not(predicate(t)), pinned)))
        return facts

    def system_axioms(self, names: set[str]) -> list[Any]:
        t = self.variable("s")
        facts: list[Any] = []
        for machine in self.system.transducers:
            if not names & set(machine.states):
                continue
            # Exactly one state at a time: the states are the values of one function.
            current = z3.Function(f"state_of_{machine.name}", z3.RealSort(), z3.IntSort())
            for index, state in enumerate(machine.states):
                facts.append(
                    z3.ForAll([t], z3.Implies(t >= 0, self.prop(state)(t) == (current(t) == index)))
                )
            size = len(machine.states)
            facts.append(
                z3.ForAll([t], z3.Implies(t >= 0, z3.And(current(t) >= 0, current(t) < size)))
            )
            if machine.initial is not None:
                facts.append(self.prop(machine.initial)(z3.RealVal(0)))
        for a, b in self.system.exclusive:
            if a in names and b in names:
                facts.append(z3.ForAll([t], z3.Not(z3.And(self.prop(a)(t), self.prop(b)(t)))))
        for name in self.system.never:
            if name in names:
                facts.append(z3.ForAll([t], z3.Not(self.prop(name)(t))))
        return facts


def _plain(f: Any) -> Any:
    """The formula without double negations (the same in three values too)."""
    while f[0] == "not" and f[1][0] == "not":
        f = f[1][1]
    return f


def refute(
    formulas: Sequence[Any], system: System, names: set[str], limits: Limits
) -> tuple[str, tuple[int, ...]]:
    """("unsat", the formulas in a conflict) when no trace makes all the formulas
    true at one time; ("limit", ()) when the solver's limit cut it short;
    ("unknown", ()) otherwise."""
    refuter = Refuter(system)
    solver = z3.Solver()
    limits.configure(solver)
    solver.set("unsat_core", True)
    # As in the witness search: time 0 is no restriction for formulas about the
    # future alone, unless the system fixes how traces start.
    starts = any(m.initial is not None for m in system.relevant(names))
    if starts or any(facts(f).has_past for f in formulas):
        at = z3.Real("tau")
        solver.add(at >= 0)
    else:
        at = z3.RealVal(0)
    labels = []
    for index, f in enumerate(formulas):
        label = z3.Bool(f"requirement{index}")
        labels.append(label)
        solver.assert_and_track(refuter.encode(f, 1, at), label)
    solver.add(*refuter.axioms, *refuter.pinned_durations(), *refuter.system_axioms(names))
    checkpoint()
    result = solver.check()
    if result == z3.unknown and solver.reason_unknown() in (
        "timeout",
        "canceled",
        "max. resource limit exceeded",
    ):
        return "limit", ()
    if result != z3.unsat:
        return "unknown", ()
    core = {str(item) for item in solver.unsat_core()}
    return "unsat", tuple(i for i, label in enumerate(labels) if str(label) in core)
