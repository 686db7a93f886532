"""The online monitor agrees with the reference evaluator at every time point, on
random formulas (nesting up to 5, bounds up to 100) and random traces, fed in one
go or cut anywhere: a cut trace's true/false verdicts are final."""

from __future__ import annotations

from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rmvdsl.logic.reference import Reference, Trace
from rmvdsl.runtime.rmtld3 import Monitor, merge

PROPS = ["a", "b", "c"]
BOUNDS = st.one_of(st.integers(0, 12), st.integers(0, 100)).map(Fraction)
OPS = st.sampled_from(["<", "<=", "="])


def formulas(depth: int = 5) -> st.SearchStrategy:
    leaf = st.one_of(
        st.sampled_from(PROPS).map(lambda p: ("prop", p)),
        st.booleans().map(lambda v: ("const", v)),
    )
    if depth == 0:
        return leaf
    sub = formulas(depth - 1)
    return st.one_of(
        leaf,
        sub.map(lambda f: ("not", f)),
        st.tuples(st.sampled_from(["and", "or"]), sub, sub),
        st.tuples(st.sampled_from(["until", "since"]), OPS, BOUNDS, sub, sub),
        st.tuples(
            st.just("cmp"),
            st.sampled_from(["<", "<=", ">", ">=", "==", "!="]),
            st.tuples(st.just("dur"), BOUNDS.filter(lambda b: b > 0), sub),
            st.one_of(
                st.integers(0, 10).map(lambda n: ("num", Fraction(n))),
                st.tuples(st.just("dur"), BOUNDS.filter(lambda b: b > 0), sub),
            ),
        ),
    )


@st.composite
def traces(draw) -> Trace:
    count = draw(st.integers(1, 8))
    gaps = draw(st.lists(st.integers(1, 8), min_size=count, max_size=count))
    times = [Fraction(0)]
    for gap in gaps[:-1]:
        times.append(times[-1] + gap)
    states = [frozenset(draw(st.sets(st.sampled_from(PROPS)))) for _ in times]
    end = times[-1] + gaps[-1]
    return Trace(times, states, end)


def monitored(formula, trace: Trace, end: Fraction, one_by_one: bool) -> list:
    monitor = Monitor(formula)
    samples = [(t, s) for t, s in zip(trace.times, trace.states, strict=True) if t < end]
    if one_by_one:
        for t, s in samples:
            monitor.step(t, s)
    else:
        monitor.feed(samples)
    monitor.end(end)
    return merge(monitor.verdicts())


def value_at(segments: list, t: Fraction) -> str:
    for a, b, a_closed, b_closed, value in segments:
        if (a < t or (a == t and a_closed)) and (t < b or (t == b and b_closed)):
            return value
    raise AssertionError(f"no verdict at {t}")


def probe_points(segments: list) -> list[Fraction]:
    points = []
    for a, b, *_ in segments:
        points += [a, b, (a + b) / 2]
    return points


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(formulas(), traces(), st.booleans())
def test_monitor_equals_reference_everywhere(formula, trace, one_by_one):
    expected = Reference(trace).segments(formula)
    got = monitored(formula, trace, trace.end, one_by_one)
    assert got == expected


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(formulas(4), traces(), st.data())
def test_cut_traces_never_flip(formula, trace, data):
    cut = data.draw(st.integers(1, int(trace.end)).map(Fraction))
    cut_trace = Trace(
        [t for t in trace.times if t < cut],
        [s for t, s in zip(trace.times, trace.states, strict=True) if t < cut],
        cut,
    )
    early = monitored(formula, cut_trace, cut, one_by_one=False)
    assert early == Reference(cut_trace).segments(formula)
    final = Reference(trace).segments(formula)
    for t in probe_points(early):
        if t < cut:
            before = value_at(early, t)
            if before != "unknown":
                assert value_at(final, t) == before, (t, before)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(formulas())
def test_one_traversal_gives_the_monitors_horizon(formula):
    """`facts` (used by the solver) and the monitor's nodes compute the horizon each
    their own way: they must agree."""
    from rmvdsl.runtime.rmtld3 import facts

    found = facts(formula)
    monitor = Monitor(formula)
    assert (found.future, found.past) == (monitor.root.future, monitor.root.past)
    names = [n for n in PROPS if n in str(formula)]
    assert sorted(found.propositions) == sorted(n for n in names if ("prop", n) in _nodes(formula))
    assert found.has_past == any(node[0] == "since" for node in _nodes(formula))


def _nodes(formula) -> list:
    out, stack = [], [formula]
    while stack:
        node = stack.pop()
        out.append(node)
        stack += [c for c in node[1:] if isinstance(c, tuple)]
    return out


def windows(depth: int = 4) -> st.SearchStrategy:
    """`eventually` and `once` (one sweep in the monitor) nested with the rest."""
    leaf = st.sampled_from(PROPS).map(lambda p: ("prop", p))
    if depth == 0:
        return leaf
    sub = windows(depth - 1)
    kinds, bounds = st.sampled_from(["until", "since"]), st.integers(0, 6).map(Fraction)
    window = st.tuples(kinds, OPS, bounds, st.just(("const", True)), sub)
    # `always` and `historically`: isolated points, where the window ends matter
    dual = st.tuples(kinds, OPS, bounds, st.just(("const", True)), sub.map(lambda f: ("not", f)))
    return st.one_of(
        leaf,
        sub.map(lambda f: ("not", f)),
        st.tuples(st.sampled_from(["and", "or"]), sub, sub),
        window,
        dual.map(lambda f: ("not", f)),
    )


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(windows(), traces(), st.booleans())
def test_window_sweep_equals_reference(formula, trace, one_by_one):
    assert monitored(formula, trace, trace.end, one_by_one) == Reference(trace).segments(formula)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(windows(), traces(), st.randoms(use_true_random=False))
def test_window_sweep_equals_pointwise_with_late_input(formula, trace, random):
    """Out-of-order input makes stretches unknown: the sweep reads three values the
    way the pointwise evaluation does."""
    from rmvdsl.runtime import rmtld3

    samples = list(zip(trace.times, trace.states, strict=True))
    random.shuffle(samples)

    def run() -> list:
        monitor = Monitor(formula, lateness=Fraction(random_lateness))
        for t, s in samples:
            monitor.step(t, s)
        monitor.end(trace.end)
        return [*merge(monitor.verdicts()), *monitor.beyond()]

    random_lateness = random.randint(0, 4)
    swept = run()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rmtld3.Temporal, "update", rmtld3.Evaluated.update)
        pointwise = run()
    assert swept == pointwise


@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
@given(st.one_of(windows(3), formulas(2)), st.randoms(use_true_random=False))
def test_batches_of_any_size_give_the_same_verdicts(formula, random):
    """A long trace (300 changes) gives the same segments whether the monitor
    recomputes after every change that passes the horizon or in batches."""
    from rmvdsl.runtime import rmtld3

    t, samples = Fraction(0), []
    for _ in range(300):
        samples.append((t, frozenset(random.sample(PROPS, random.randint(0, 3)))))
        t += random.randint(1, 6)

    def run() -> list:
        monitor = Monitor(formula)
        monitor.feed(samples)
        monitor.end(t)
        return [*merge(monitor.verdicts()), *monitor.beyond()]

    batched = run()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rmtld3, "BATCH", 1)
        patch.setattr(rmtld3, "SPARSE_HORIZONS", 1)
        assert run() == batched


def test_a_late_sample_is_revised_from_the_history_kept():
    """Found by the test above: a sample late by two seconds under a two-second
    horizon re-evaluated nodes whose history was already dropped, and the pointwise
    evaluation then read unknown where the sweep read the kept signal."""
    from rmvdsl.runtime import rmtld3

    one = Fraction(1)
    formula = ("not", ("until", "<", one, ("const", True),
                       ("not", ("until", "<", one, ("const", True), ("prop", "a")))))  # fmt: skip
    order = [0, 1, 2, 5, 4, 6, 3]

    def run() -> list:
        monitor = Monitor(formula, lateness=Fraction(0))
        for t in order:
            monitor.step(Fraction(t), frozenset())
        monitor.end(Fraction(7))
        return [*merge(monitor.verdicts()), *monitor.beyond()]

    swept = run()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rmtld3.Temporal, "update", rmtld3.Evaluated.update)
        pointwise = run()
    assert swept == pointwise
    # `a` is unknown from 3 on: the verdict is unknown from just after 2 (its horizon).
    revised = [s for s in swept if s[4] == "unknown (revised: late input)"]
    assert (Fraction(2), Fraction(4), False, True) in [s[:4] for s in revised]
