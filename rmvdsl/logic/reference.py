"""The reference evaluator: the definitions of docs/semantics.md, written down
directly, for small traces. The tests use it as the oracle for the online monitor.

A value at time t is computed by recursion on the formula. Quantifiers over a time
window range over finitely many candidates: every point where a subformula can
change value inside the window, and one point inside each open interval between
two such points (a subformula is constant there). Arithmetic is exact (Fraction).
"""

from __future__ import annotations

import bisect
import itertools
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from rmvdsl.runtime.rmtld3 import arithmetic, compare, continues, extended

FALSE, UNKNOWN, TRUE = 0, 1, 2


@dataclass
class Trace:
    """State i holds on [times[i], times[i+1]); the last until `end`. Time starts at
    times[0]; nothing is known from `end` on."""

    times: list[Fraction]
    states: list[frozenset[str]]
    end: Fraction

    @property
    def start(self) -> Fraction:
        return self.times[0]

    def prop(self, name: str, t: Fraction) -> int:
        if t >= self.end:
            return UNKNOWN
        if t < self.start:
            return FALSE
        low, high = 0, len(self.times) - 1
        while low < high:  # the last change at or before t
            middle = (low + high + 1) // 2
            if self.times[middle] <= t:
                low = middle
            else:
                high = middle - 1
        return TRUE if name in self.states[low] else FALSE


@dataclass
class Reference:
    trace: Trace
    _values: dict[tuple[int, Fraction], int] = field(default_factory=dict)
    _points: dict[int, list[Fraction]] = field(default_factory=dict)

    # ---- where a formula can change value ----

    def points(self, f: Any) -> list[Fraction]:
        key = id(f)
        if key not in self._points:
            self._points[key] = sorted(self._compute_points(f))
        return self._points[key]

    def _compute_points(self, f: Any) -> set[Fraction]:
        kind = f[0]
        if kind == "prop":
            return {*self.trace.times, self.trace.end}
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
            extra = {self.trace.start + f[2]} if kind == "since" else set()
            return children | {p + shift for p in children} | extra
        return self._compare_points(f)

    def _term_points(self, term: Any) -> set[Fraction]:
        if term[0] == "num":
            return set()
        if term[0] == "dur":
            body = set(self.points(term[2]))
            return body | {p - term[1] for p in body}
        return self._term_points(term[1]) | self._term_points(term[2])

    def _compare_points(self, f: Any) -> set[Fraction]:
        pieces = sorted(self._term_points(f[2]) | self._term_points(f[3]) | {self.trace.start})
        pieces.append(pieces[-1] + 1)
        found = set(pieces[:-1])
        for a, b in itertools.pairwise(pieces):
            (la, ha), (lb, hb) = self.term(f[2], a), self.term(f[3], a)
            (la2, ha2), (lb2, hb2) = self.term(f[2], b), self.term(f[3], b)
            for at_a, at_b in ((ha - lb, ha2 - lb2), (la - hb, la2 - hb2)):
                if (at_a < 0 < at_b) or (at_b < 0 < at_a):
                    found.add(a + (b - a) * Fraction(-at_a) / (at_b - at_a))
        return found

    def candidates(
        self, f_list: list[Any], low: Fraction, high: Fraction
    ) -> list[tuple[Fraction, bool]]:
        """Points in [low, high] where any of the formulas can change, with one
        point inside each open gap: (time, is_a_breakpoint)."""
        inside = {low, high}
        for f in f_list:
            points = self.points(f)  # sorted
            inside.update(
                points[bisect.bisect_right(points, low) : bisect.bisect_left(points, high)]
            )
        ordered = sorted(inside)
        out = []
        for a, b in itertools.pairwise(ordered):
            out.append((a, True))
            out.append(((a + b) / 2, False))
        out.append((ordered[-1], True))
        return out

    # ---- values ----

    def value(self, f: Any, t: Fraction) -> int:
        key = (id(f), t)
        if key not in self._values:
            self._values[key] = self._compute(f, t)
        return self._values[key]

    def _compute(self, f: Any, t: Fraction) -> int:
        kind = f[0]
        if kind == "prop":
            return self.trace.prop(f[1], t)
        if kind == "const":
            return TRUE if f[1] else FALSE
        if kind == "not":
            return 2 - self.value(f[1], t)
        if kind == "and":
            return min(self.value(f[1], t), self.value(f[2], t))
        if kind == "or":
            return max(self.value(f[1], t), self.value(f[2], t))
        if kind == "until":
            return self._until(f, t)
        if kind == "since":
            return self._since(f, t)
        return self._compare(f, t)

    def _until(self, f: Any, t: Fraction) -> int:
        _, op, bound, phi, psi = f
        end = t + bound
        best = FALSE
        before = TRUE  # phi over [t, s): every earlier sample
        for s, is_point in self.candidates([phi, psi], t, end):
            in_window = (
                (op == "=" and s == end) or (op == "<" and s < end) or (op == "<=" and s <= end)
            )
            if in_window:
                here = self.value(psi, s)
                if not is_point:  # s inside a gap: phi holds on the open part (., s) too
                    here = min(here, self.value(phi, s))
                best = max(best, min(here, before))
            before = min(before, self.value(phi, s))
            if best == TRUE or before == FALSE:  # no later s can change the value
                break
        return best

    def _since(self, f: Any, t: Fraction) -> int:
        _, op, bound, phi, psi = f
        begin = self.trace.start - 1 if bound is None else t - bound  # no bound: from the start
        low = max(begin, self.trace.start)
        if low > t:
            return FALSE
        best = FALSE
        after = TRUE  # phi over (s, t]: every later sample
        for s, is_point in reversed(self.candidates([phi, psi], low, t)):
            in_window = s == begin if op == "=" else s != begin or op == "<="
            if in_window:
                here = self.value(psi, s)
                if not is_point:  # s inside a gap: phi holds on the open part (s, .) too
                    here = min(here, self.value(phi, s))
                best = max(best, min(here, after))
            after = min(after, self.value(phi, s))
            if best == TRUE or after == FALSE:  # no earlier s can change the value
                break
        return best

    def _compare(self, f: Any, t: Fraction) -> int:
        _, op, a, b = f
        # The comparison of two intervals is shared with the monitor: it is the
        # definition itself (docs/semantics.md), small enough to read at a glance.
        return compare(op, self.term(a, t), self.term(b, t))

    def term(self, term: Any, t: Fraction) -> tuple[Fraction, Fraction]:
        kind = term[0]
        if kind == "num":
            return Fraction(term[1]), Fraction(term[1])
        if kind == "dur":
            window, body = term[1], term[2]
            surely = possibly = Fraction(0)
            samples = self.candidates([body], t, t + window)
            for index in range(1, len(samples), 2):  # the gaps: (previous point, next point)
                a, b = samples[index - 1][0], samples[index + 1][0]
                value = self.value(body, samples[index][0])
                if value == TRUE:
                    surely += b - a
                if value != FALSE:
                    possibly += b - a
            return surely, possibly
        return arithmetic(kind, self.term(term[1], t), self.term(term[2], t))

    # ---- the whole signal ----

    def segments(self, f: Any) -> list[tuple[Fraction, Fraction, bool, bool, str]]:
        """The value at every time point of [start, end), as maximal segments."""
        names = {FALSE: "false", UNKNOWN: "unknown", TRUE: "true"}
        start, end = self.trace.start, self.trace.end
        out: list[tuple[Fraction, Fraction, bool, bool, str]] = []
        samples = self.candidates([f], start, end)
        for index, (s, is_point) in enumerate(samples):
            if s >= end:
                break
            name = names[self.value(f, s)]
            if is_point:
                a = b = s
                a_closed = b_closed = True
            else:
                a, b = samples[index - 1][0], samples[index + 1][0]
                a_closed = b_closed = False
            segment = (a, b, a_closed, b_closed, name)
            if out and continues(out[-1], segment):
                out[-1] = extended(out[-1], segment)
            else:
                out.append(segment)
        return out


def evaluate(formula: Any, trace: Trace, t: Fraction) -> str:
    names = {FALSE: "false", UNKNOWN: "unknown", TRUE: "true"}
    return names[Reference(trace).value(formula, Fraction(t))]
