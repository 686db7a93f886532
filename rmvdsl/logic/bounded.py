"""The bounded witness search: traces of k segments with symbolic change times.

A trace of k segments has change times 0 = t_0 < t_1 < ... < t_(k-1) (z3 reals)
and a set of propositions per segment (z3 booleans); the last segment runs
forever. Every subformula is piecewise constant with breakpoints at the change
times shifted by the bounds of the operators above it (docs/semantics.md), so its
value anywhere is decided by its value at those points and just right of them.
The encoding is that construction of the reference evaluator, lifted to symbolic
points: `value(f, e, plus)` is f at the time e (plus=False) or on (e, e + epsilon)
(plus=True), where a time is a change time (or 0, or the evaluation time) plus a
constant. Bounds are constants in the formulas, so a bound of 1000 costs no more
than a bound of 5: nothing is unrolled per time unit.

Found traces are only candidates: the caller replays each through the reference
evaluator before it is believed.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from fractions import Fraction
from typing import Any

import z3
from z3 import z3core

from rmvdsl.logic.bounded_temporal import TemporalEncoding
from rmvdsl.logic.folded import EVAL, Bool, Time, and_, as_z3, not_, or_


def propositional(f: Any) -> bool:
    if f[0] in ("prop", "const"):
        return True
    if f[0] == "not":
        return propositional(f[1])
    if f[0] in ("and", "or"):
        return propositional(f[1]) and propositional(f[2])
    return False


class EncodingTimeout(Exception):
    """Building the encoding took longer than the question's time limit."""


class BoundedTrace(TemporalEncoding):
    """The symbolic trace and the encoding of formulas over it."""

    def __init__(self, segments: int, names: list[str], evaluation_free: bool) -> None:
        self.k = segments
        self.names = names
        self.changes = [z3.RealVal(0)] + [z3.Real(f"t{i}") for i in range(1, segments)]
        self.holds = [{n: z3.Bool(f"s{i}_{n}") for n in names} for i in range(segments)]
        self.evaluation = z3.Real("tau") if evaluation_free else None
        self.structure: list[Any] = [
            self.changes[i] < self.changes[i + 1] for i in range(segments - 1)
        ]
        if self.evaluation is not None:
            self.structure.append(self.evaluation >= 0)
        # Where two duration terms cross: z3 reals defined by `definitions`.
        self.crossings: list[Any] = []
        self.definitions: list[Any] = []
        self._values: dict[tuple[int, Time, bool], Bool] = {}
        self._points: dict[int, frozenset[Time]] = {}
        self._keep: list[Any] = []  # nodes whose id() keys the caches
        self._less: dict[tuple[Time, Time], Bool] = {}
        self._segments: dict[tuple[int, Time], Bool] = {}
        self._raw_holds: list[list[tuple[str, Any]]] | None = None
        # What callers derive from this trace alone (the spec's constraints on it).
        self.derived: dict[str, list[Any]] = {}
        # Deeply nested formulas make many candidate points: building the encoding
        # stops at this time.monotonic() (the caller sets it per question).
        self.deadline = float("inf")

    # ---- times ----

    def z3_time(self, time: Time) -> Any:
        base, offset = time
        if base >= 0:
            symbol = self.changes[base]
        elif base == EVAL:
            symbol = self.evaluation
        else:
            symbol = self.crossings[-base - 2]
        if offset == 0:
            return symbol
        return symbol + z3.RealVal(str(offset))

    def less(self, a: Time, b: Time) -> Bool:
        if a[0] == b[0]:
            return a[1] < b[1]
        if a[0] >= 0 and b[0] >= 0:  # change times are ordered
            if a[0] < b[0] and a[1] <= b[1]:
                return True
            if a[0] > b[0] and a[1] >= b[1]:
                return False
        # The same comparison comes back for every formula over these times: made
        # once (a z3 comparison costs tens of microseconds in Python).
        found = self._less.get((a, b))
        if found is None:
            found = self._less[(a, b)] = self.z3_time(a) < self.z3_time(b)
        return found

    def less_equal(self, a: Time, b: Time) -> Bool:
        return not_(self.less(b, a))

    def equal(self, a: Time, b: Time) -> Bool:
        if a[0] == b[0]:
            return a[1] == b[1]
        return and_(self.less_equal(a, b), self.less_equal(b, a))

    # ---- where a formula can change ----

    def points(self, f: Any) -> frozenset[Time]:
        key = id(f)
        if key not in self._points:
            self._keep.append(f)
            self._points[key] = frozenset(self._compute_points(f))
        return self._points[key]

    def _compute_points(self, f: Any) -> set[Time]:
        kind = f[0]
        if kind == "prop":
            return {(i, Fraction(0)) for i in range(self.k)}
        if kind == "const":
            return set()
        if kind == "not":
            return set(self.points(f[1]))
        if kind in ("and", "or"):
            return set(self.points(f[1])) | set(self.points(f[2]))
        if kind in ("until", "since"):
            children = set(self.points(f[3])) | set(self.points(f[4]))
            if f[2] is None:  # a `since` with no bound changes with its children only
                return children
            shift = -f[2] if kind == "until" else f[2]
            extra = {(0, Fraction(f[2]))} if kind == "since" else set()
            return children | {(b, o + shift) for b, o in children} | extra
        pieces = self._term_points(f[2]) | self._term_points(f[3])
        return pieces | self.crossing_points(f, pieces)

    def crossing_points(self, f: Any, pieces: set[Time]) -> set[Time]:
        """A comparison of durations also changes where the two sides cross: at most
        once between two consecutive breakpoints of the terms, where the difference
        is linear. One crossing point per breakpoint (the breakpoint itself when
        the sides do not cross before the next one)."""
        _, _, left, right = f
        rates = _rates(("sub", left, right))
        out = set()
        ordered = sorted(pieces)
        for p in ordered:
            here = self.z3_time(p)
            gap = self.term(left, p) - self.term(right, p)
            rate = self.slope(left, p) - self.slope(right, p)
            cross = here
            for r in sorted(rates - {Fraction(0)}):
                cross = z3.If(rate == z3.RealVal(str(r)), here - gap / z3.RealVal(str(r)), cross)
            ahead = z3.BoolVal(True)
            for q in ordered:
                later = self.less(p, q)
                if later is not False:
                    ahead = z3.And(ahead, z3.Implies(as_z3(later), cross < self.z3_time(q)))
            symbol = z3.Real(f"x{len(self.crossings)}")
            self.crossings.append(symbol)
            self.definitions.append(symbol == z3.If(z3.And(cross > here, ahead), cross, here))
            out.add((-1 - len(self.crossings), Fraction(0)))
        return out

    def _term_points(self, term: Any) -> set[Time]:
        if term[0] == "num":
            return set()
        if term[0] == "dur":
            body = self.points(term[2])
            return set(body) | {(b, o - term[1]) for b, o in body}
        return self._term_points(term[1]) | self._term_points(term[2])

    # ---- values ----

    def value(self, f: Any, at: Time, plus: bool = False) -> Bool:
        key = (id(f), at, plus)
        if key not in self._values:
            self._keep.append(f)
            if len(self._values) % 256 == 0 and time.monotonic() > self.deadline:
                raise EncodingTimeout
            self._values[key] = self._compute(f, at, plus)
        return self._values[key]

    def _compute(self, f: Any, at: Time, plus: bool) -> Bool:
        kind = f[0]
        if kind == "prop":
            return self.prop(f[1], at)
        if kind == "const":
            return bool(f[1])
        if kind == "not":
            return not_(self.value(f[1], at, plus))
        if kind == "and":
            return and_(self.value(f[1], at, plus), self.value(f[2], at, plus))
        if kind == "or":
            return or_(self.value(f[1], at, plus), self.value(f[2], at, plus))
        if kind in ("until", "since") and f[1] == "<" and f[2] == 0:
            return False  # an empty window: no t' at all
        if kind == "until":
            return self.until_plus(f, at) if plus else self.until(f, at)
        if kind == "since":
            return self.since_plus(f, at) if plus else self.since(f, at)
        return self.compare(f, at, plus)

    def segment(self, i: int, at: Time) -> Bool:
        """Whether `at` lies in segment i, [t_i, t_(i+1))."""
        found = self._segments.get((i, at))
        if found is not None:
            return found
        start = (i, Fraction(0))
        inside = self.less_equal(start, at)
        if i + 1 < self.k:
            inside = and_(inside, self.less(at, (i + 1, Fraction(0))))
        self._segments[(i, at)] = inside
        return inside

    def prop(self, name: str, at: Time) -> Bool:
        # Segments are closed on the left: a proposition's value just right of a
        # time is its value at that time.
        return or_(*(and_(self.segment(i, at), self.holds[i][name]) for i in range(self.k)))

    def holds_on(
        self, phi: Any, low: Time, high: Time, low_closed: bool, high_closed: bool
    ) -> Bool:
        """phi at every time between low and high (each end included or not)."""
        parts = [self.value(phi, low, True)]
        if low_closed:
            parts.append(self.value(phi, low))
        if high_closed:
            parts.append(self.value(phi, high))
        for p in self.points(phi):
            between = and_(self.less(low, p), self.less(p, high))
            if between is False:
                continue
            parts.append(or_(not_(between), and_(self.value(phi, p), self.value(phi, p, True))))
        return and_(*parts)

    def shifted(self, at: Time, delta: Fraction) -> Time:
        return (at[0], at[1] + delta)

    def compare(self, f: Any, at: Time, plus: bool) -> Bool:
        _, op, left, right = f
        x, y = self.term(left, at), self.term(right, at)
        if op in (">", ">="):
            op, x, y, left, right = {">": "<", ">=": "<="}[op], y, x, right, left
        if not plus:
            relation = {"<": x < y, "<=": x <= y, "==": x == y, "!=": x != y}[op]
            return relation
        # Just right of `at`: the values, then which way they move.
        dx, dy = self.slope(left, at), self.slope(right, at)
        if op == "<":
            return z3.Or(x < y, z3.And(x == y, dx < dy))
        if op == "<=":
            return z3.Or(x < y, z3.And(x == y, dx <= dy))
        equal = z3.And(x == y, dx == dy)
        return equal if op == "==" else z3.Not(equal)

    def term(self, term: Any, at: Time) -> Any:
        kind = term[0]
        if kind == "num":
            return z3.RealVal(str(Fraction(term[1])))
        if kind == "dur":
            return self.measure(term[2], at, self.shifted(at, Fraction(term[1])))
        left, right = self.term(term[1], at), self.term(term[2], at)
        return {"add": left + right, "sub": left - right, "mul": left * right}[kind]

    def slope(self, term: Any, at: Time) -> Any:
        """The derivative from the right: a duration grows where its body holds at
        the window's end and shrinks where it held at the start."""
        kind = term[0]
        if kind == "num":
            return z3.RealVal(0)
        if kind == "dur":
            end = self.shifted(at, Fraction(term[1]))
            return z3.If(as_z3(self.value(term[2], end, True)), 1, 0) - z3.If(
                as_z3(self.value(term[2], at, True)), 1, 0
            )
        left, right = self.slope(term[1], at), self.slope(term[2], at)
        if kind == "add":
            return left + right
        if kind == "sub":
            return left - right
        # a product has a constant side (the compiler refuses two durations)
        if term[1][0] == "num":
            return self.term(term[1], at) * right
        return left * self.term(term[2], at)

    def measure(self, body: Any, low: Time, high: Time) -> Any:
        """How long body holds in [low, high)."""
        a, b = self.z3_time(low), self.z3_time(high)
        if propositional(body):
            total = z3.RealVal(0)
            for i in range(self.k):
                start = self.changes[i]
                stop = self.changes[i + 1] if i + 1 < self.k else b
                overlap = _min(stop, b) - _max(start, a)
                held = as_z3(self._segment_value(body, i))
                total = total + z3.If(z3.And(held, overlap > 0), overlap, 0)
            return total
        # Temporal body: sum over the pieces between its breakpoints.
        points = sorted(self.points(body))
        total = z3.RealVal(0)
        starts = [low, *points]
        for index, q in enumerate(starts):
            inside = True if index == 0 else and_(self.less(low, q), self.less(q, high))
            if inside is False:
                continue
            first = and_(*(not_(self.equal(q, other)) for other in starts[1:index]))
            following = b
            for p in points:
                after = as_z3(self.less(q, p))
                following = z3.If(
                    z3.And(after, self.z3_time(p) < following), self.z3_time(p), following
                )
            held = as_z3(and_(inside, first, self.value(body, q, True)))
            total = total + z3.If(held, following - self.z3_time(q), 0)
        return total

    def _segment_value(self, f: Any, i: int) -> Bool:
        kind = f[0]
        if kind == "prop":
            return self.holds[i][f[1]]
        if kind == "const":
            return bool(f[1])
        if kind == "not":
            return not_(self._segment_value(f[1], i))
        parts = (self._segment_value(f[1], i), self._segment_value(f[2], i))
        return and_(*parts) if kind == "and" else or_(*parts)

    # ---- reading a model ----

    def _held_asts(self) -> list[list[tuple[str, Any]]]:
        """Each segment's names and their variables' C pointers (kept alive by
        `holds`), in the order of `names`."""
        if self._raw_holds is None:
            self._raw_holds = [
                [(n, segment[n].as_ast()) for n in self.names] for segment in self.holds
            ]
        return self._raw_holds

    def read(self, model: Any) -> tuple[list[Fraction], list[frozenset[str]], Fraction]:
        times = [_fraction(model.eval(t, model_completion=True)) for t in self.changes]
        states = [frozenset(held_in(model, segment)) for segment in self._held_asts()]
        at = (
            _fraction(model.eval(self.evaluation, model_completion=True))
            if self.evaluation is not None
            else Fraction(0)
        )
        return times, states, at


def _rates(term: Any) -> set[Fraction]:
    """The slopes a term can have: a duration grows by 1, 0 or -1 per time unit."""
    kind = term[0]
    if kind == "num":
        return {Fraction(0)}
    if kind == "dur":
        return {Fraction(-1), Fraction(0), Fraction(1)}
    left, right = _rates(term[1]), _rates(term[2])
    if kind == "add":
        return {a + b for a in left for b in right}
    if kind == "sub":
        return {a - b for a in left for b in right}
    factor = Fraction(term[1][1]) if term[1][0] == "num" else Fraction(term[2][1])
    rates = right if term[1][0] == "num" else left
    return {factor * r for r in rates}


def _min(a: Any, b: Any) -> Any:
    return z3.If(a < b, a, b)


def _max(a: Any, b: Any) -> Any:
    return z3.If(a > b, a, b)


def held_in(model: Any, variables: list[tuple[str, Any]]) -> Iterator[str]:
    """The names whose boolean variable is true in `model` (false where it has no
    value), read through z3's C API: a trace of 20 propositions read one
    `model.eval` at a time took 1 ms, a fifth of a whole satisfiability question,
    in the Python objects each value is wrapped in and unwrapped from."""
    context, raw_model = model.ctx.ref(), model.model
    result = (z3.Ast * 1)()
    for name, variable in variables:
        if not z3core.Z3_model_eval(context, raw_model, variable, True, result):
            raise z3.Z3Exception(f"no value for {name} in the model")
        if z3core.Z3_get_bool_value(context, result[0]) == z3.Z3_L_TRUE:
            yield name


def _fraction(value: Any) -> Fraction:
    if z3.is_rational_value(value):
        return Fraction(value.numerator_as_long(), value.denominator_as_long())
    if z3.is_algebraic_value(value):  # pragma: no cover - linear problems give rationals
        return Fraction(value.approx(20).as_fraction())
    return Fraction(0)
