"""The bounded encoding of RMTLD3's until and since (bounded, exact `=` bounds, and
their values just right of a point): a part of BoundedTrace."""

from __future__ import annotations

from collections.abc import Callable
from fractions import Fraction
from typing import Any

from rmvdsl.logic.folded import ZERO, Bool, Time, and_, or_


class TemporalEncoding:
    """until and since over the symbolic trace (BoundedTrace's, which this is a part of)."""

    value: Callable[..., Bool]
    less: Callable[[Time, Time], Bool]
    less_equal: Callable[[Time, Time], Bool]
    equal: Callable[[Time, Time], Bool]
    points: Callable[[Any], frozenset[Time]]
    shifted: Callable[[Time, Fraction], Time]
    holds_on: Callable[..., Bool]

    def until(self, f: Any, at: Time) -> Bool:
        _, op, bound, phi, psi = f
        end = self.shifted(at, Fraction(bound))
        if bound == 0:
            return self.value(psi, at)
        if op == "=":
            return and_(self.value(psi, end), self.holds_on(phi, at, end, True, False))
        options = [
            self.value(psi, at),
            and_(self.value(psi, at, True), self.value(phi, at), self.value(phi, at, True)),
        ]
        for c in self.points(phi) | self.points(psi):
            after = self.less(at, c)
            if after is False:
                continue
            before_end = self.less(c, end) if op == "<" else self.less_equal(c, end)
            upto = self.holds_on(phi, at, c, True, False)
            options.append(and_(after, before_end, self.value(psi, c), upto))
            inside = and_(after, self.less(c, end))
            options.append(
                and_(
                    inside,
                    self.value(psi, c, True),
                    upto,
                    self.value(phi, c),
                    self.value(phi, c, True),
                )
            )
        if op == "<=":
            options.append(and_(self.value(psi, end), self.holds_on(phi, at, end, True, False)))
        return or_(*options)

    def until_plus(self, f: Any, at: Time) -> Bool:
        """The value on (at, at + epsilon)."""
        _, op, bound, phi, psi = f
        end = self.shifted(at, Fraction(bound))
        if bound == 0:
            return self.value(psi, at, True)
        if op == "=":
            return and_(
                self.value(psi, end, True),
                self.holds_on(phi, at, end, False, True),
                self.value(phi, end, True),
            )
        options = [
            self.value(psi, at, True),
            # the window's end: its point and just right of it
            and_(self.value(psi, end), self.holds_on(phi, at, end, False, False)),
            and_(
                self.value(psi, end, True),
                self.holds_on(phi, at, end, False, True),
                self.value(phi, end, True),
            ),
        ]
        for c in self.points(phi) | self.points(psi):
            inside = and_(self.less(at, c), self.less_equal(c, end))
            if inside is False:
                continue
            upto = self.holds_on(phi, at, c, False, False)
            options.append(and_(inside, self.value(psi, c), upto))
            options.append(
                and_(
                    inside,
                    self.value(psi, c, True),
                    upto,
                    self.value(phi, c),
                    self.value(phi, c, True),
                )
            )
        return or_(*options)

    def _window(self, at: Time, bound: Any) -> Time | None:
        """Where a `since` window begins; None when it has no bound (from time 0)."""
        return None if bound is None else self.shifted(at, -Fraction(bound))

    def _after_begin(self, begin: Time | None, c: Time, strict: bool) -> Bool:
        if begin is None:
            return True
        return self.less(begin, c) if strict else self.less_equal(begin, c)

    def since(self, f: Any, at: Time) -> Bool:
        _, op, bound, phi, psi = f
        begin = self._window(at, bound)
        started = self.less_equal(ZERO, at)
        if bound == 0:
            return and_(started, self.value(psi, at))
        if op == "=" and begin is not None:  # (with no bound, op is "<=")
            return and_(
                started,
                self.less_equal(ZERO, begin),
                self.value(psi, begin),
                self.holds_on(phi, begin, at, False, True),
            )
        options = [and_(started, self.value(psi, at))]
        candidates = self.points(phi) | self.points(psi) | {ZERO}
        candidates |= set() if begin is None else {begin}
        for c in candidates:
            after_start = self.less_equal(ZERO, c)
            before = self.less(c, at)
            if after_start is False or before is False:
                continue
            in_window = self._after_begin(begin, c, op == "<")
            upto = self.holds_on(phi, c, at, False, True)
            options.append(and_(after_start, before, in_window, self.value(psi, c), upto))
            options.append(
                and_(
                    after_start,
                    before,
                    self._after_begin(begin, c, False),
                    self.value(psi, c, True),
                    upto,
                )
            )
        return or_(*options)

    def since_plus(self, f: Any, at: Time) -> Bool:
        _, op, bound, phi, psi = f
        begin = self._window(at, bound)
        started = self.less_equal(ZERO, at)
        now = self.value(phi, at, True)
        if op == "=" or bound == 0:
            if bound == 0 or begin is None:
                return and_(started, self.value(psi, at, True))
            return and_(
                self.less_equal(ZERO, begin),
                self.value(psi, begin, True),
                self.holds_on(phi, begin, at, False, True),
                now,
            )
        options = [and_(started, self.value(psi, at, True))]
        candidates = self.points(phi) | self.points(psi) | {ZERO}
        candidates |= set() if begin is None else {begin}
        for c in candidates:
            after_start = self.less_equal(ZERO, c)
            if after_start is False:
                continue
            at_most_now = self.less_equal(c, at)
            if at_most_now is not False:
                upto = or_(
                    self.equal(c, at), self.holds_on(phi, c, at, False, True)
                )  # (c, at] is empty when c is now
                options.append(
                    and_(
                        after_start,
                        at_most_now,
                        self._after_begin(begin, c, True),
                        self.value(psi, c),
                        upto,
                        now,
                    )
                )
            before = self.less(c, at)
            if before is not False:
                options.append(
                    and_(
                        after_start,
                        before,
                        self._after_begin(begin, c, False),
                        self.value(psi, c, True),
                        self.holds_on(phi, c, at, False, True),
                        now,
                    )
                )
        return or_(*options)

    # ---- durations ----
