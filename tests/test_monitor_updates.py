"""An update of the monitor's nodes may start at any time, not only where the last
one ended: a late sample re-evaluates from its own time, and a stretch it makes
unknown can merge with the unknown after the input known so far, so the next
update starts where the last one saw no breakpoint. What a `since` with a window
carries over from before that start must then be read at the start, not at its
next breakpoint."""

from __future__ import annotations

import math
import random as randoms
from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_monitor_equivalence import traces, windows

from rmvdsl.runtime import rmtld3
from rmvdsl.runtime.rmtld3 import Monitor, merge


def _signals(monitor: Monitor) -> list[tuple[list, list, list]]:
    return [(list(n.signal.starts), list(n.signal.points), list(n.signal.opens))
            for n in monitor.order]  # fmt: skip


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(windows(), traces(), st.data())
def test_an_update_from_any_time_writes_the_same_signals(formula, trace, data):
    """The input unchanged, updating every node again from any time (a breakpoint,
    or a point strictly inside an interval) writes exactly the signals it found."""
    monitor = Monitor(formula)
    monitor.feed(list(zip(trace.times, trace.states, strict=True)))
    monitor.end(trace.end)
    before = _signals(monitor)
    # From where the history kept reaches, as a late sample's update is.
    oldest = max(n.signal.starts[0] for n in monitor.order) + monitor.horizon
    last = 2 * int(trace.end)
    halves = st.integers(min(math.ceil(2 * oldest), last), last).map(lambda n: Fraction(n, 2))
    for _ in range(3):
        monitor._update_nodes(data.draw(halves))
        assert _signals(monitor) == before


def _late_run(formula, samples, end: Fraction, lateness: int) -> list:
    monitor = Monitor(formula, lateness=Fraction(lateness))
    for t, state in samples:
        monitor.step(t, state)
    monitor.end(end)
    return [*merge(monitor.verdicts()), *monitor.beyond()]


def test_a_witness_carried_into_a_late_update_is_read_at_its_start():
    """Found by test_window_sweep_equals_pointwise_with_late_input: `b` unknown up
    to 6 (late samples), false from 6 on. `a since[<1] b` is false on [7, 8), but
    the sweep kept it unknown: the update after the last late sample started at 6,
    inside what the memo had last seen as one interval, and carried "psi held just
    before the start" on to 7, as if b had held up to 7. So the outer `until` was
    unknown on (6, 8) where it is true."""
    one = Fraction(1)
    formula = ("until", "<", one, ("prop", "a"),
               ("not", ("since", "<", one, ("prop", "a"), ("prop", "b"))))  # fmt: skip
    states = {t: frozenset({"a"}) if t >= 6 else frozenset() for t in range(8)}
    samples = [(Fraction(t), states[t]) for t in (0, 6, 1, 7, 2)]
    swept = _late_run(formula, samples, Fraction(8), 0)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rmtld3.Temporal, "update", rmtld3.Evaluated.update)
        pointwise = _late_run(formula, samples, Fraction(8), 0)
    assert swept == pointwise
    assert (Fraction(6), Fraction(8), False, False, "true") in swept


def test_late_input_in_many_orders_sweeps_as_it_evaluates():
    """The same trace and formula, samples shuffled (1,000 orders, lateness 0-4):
    the sweep and the pointwise evaluation give the same segments (before the fix,
    12 of 2,000 such orders did not)."""
    one = Fraction(1)
    formula = ("until", "<", one, ("prop", "a"),
               ("not", ("since", "<", one, ("prop", "a"), ("prop", "b"))))  # fmt: skip
    trace = [(Fraction(t), frozenset({"a"}) if t >= 6 else frozenset()) for t in range(8)]
    differ = []
    for seed in range(1000):
        random = randoms.Random(seed)
        samples = trace[:]
        random.shuffle(samples)
        lateness = random.randint(0, 4)
        swept = _late_run(formula, samples, Fraction(8), lateness)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(rmtld3.Temporal, "update", rmtld3.Evaluated.update)
            if _late_run(formula, samples, Fraction(8), lateness) != swept:
                differ.append(seed)
    assert differ == []
