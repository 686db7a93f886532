"""The online monitor agrees with the reference evaluator at every time point, on
random formulas (nesting up to 5, bounds up to 100 or none on `since`) and random traces, fed in one
go or cut anywhere: a cut trace's true/false verdicts are final."""

from __future__ import annotations

import itertools
from fractions import Fraction

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from rmvdsl.logic.reference import Reference, Trace
from rmvdsl.runtime.formulas import scaled
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
        st.tuples(st.just("since"), st.just("<="), st.none(), sub, sub),  # no bound
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
    """`eventually`, `once`, `until` and `since` with a window (each one sweep in the monitor)
    nested with the rest: `always` and `historically` make isolated points, which
    end windows where they lie."""
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
        st.tuples(kinds, OPS, bounds, sub, sub),  # `until` and `since` with both sides
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


def _bounded(formula, bound: Fraction):
    """The formula with every `since` that has no bound given `bound` instead."""
    if not isinstance(formula, tuple):
        return formula
    if formula[0] == "since" and formula[2] is None:
        return ("since", "<=", bound, _bounded(formula[3], bound), _bounded(formula[4], bound))
    return tuple(_bounded(part, bound) for part in formula)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(formulas(4), traces(), st.randoms(use_true_random=False))
def test_no_bound_is_a_bound_past_the_trace_for_input_in_any_order(formula, trace, random):
    """On a trace shorter than B, `since` with no bound and `since[<=B]` are the same
    formula: fed the same samples out of order (within the lateness), the constant
    memory node and the windowed one give the same verdicts. Shorter than B with
    the formula's horizon past the end: a verdict near the end reads values up to
    a horizon after it (`duration[4](not once a)` at the end of a 1 s trace reads
    `once a` at 4 s, which `once[<=2]` no longer knows)."""
    samples = list(zip(trace.times, trace.states, strict=True))
    random.shuffle(samples)

    def run(f) -> list:
        monitor = Monitor(f, lateness=trace.end)
        for t, s in samples:
            monitor.step(t, s)
        monitor.end(trace.end)
        return merge(monitor.verdicts())  # after the end, a bound expires and none does

    from rmvdsl.runtime.rmtld3 import facts

    assert run(formula) == run(_bounded(formula, trace.end + facts(formula).future + 1))


@pytest.mark.parametrize(
    "formula",
    [
        ("since", "<=", None, ("prop", "a"), ("prop", "b")),
        ("not", ("since", "<=", None, ("const", True), ("not", ("prop", "a")))),  # historically
        ("until", "<", 50, ("prop", "a"), ("since", "<=", None, ("const", True), ("prop", "b"))),
    ],
)
def test_no_bound_keeps_memory_constant(formula):
    """100,000 changes: what the monitor holds does not grow with the trace."""
    monitor = Monitor(formula)
    sizes = []
    for block in range(20):
        samples = [(block * 50_000 + t * 10, frozenset("ab"[: t % 3])) for t in range(5_000)]
        monitor.feed(samples)
        list(monitor.verdicts())
        sizes.append(monitor.memory())
    assert max(sizes) < 2_000, sizes
    assert max(sizes[5:]) <= 2 * min(sizes[5:]) + 20, sizes


def _pointed(depth: int) -> st.SearchStrategy:
    """Formulas whose values have isolated points: `always[<c] p` holds at the start
    of a stretch of p exactly c long only, `once[=c] p` at the end of one."""
    small = st.integers(1, 3).map(Fraction)
    prop = st.sampled_from(PROPS).map(lambda p: ("prop", p))
    if depth == 0:
        return prop
    sub = _pointed(depth - 1)
    always = st.tuples(small, sub).map(
        lambda c: ("not", ("until", "<", c[0], ("const", True), ("not", c[1])))
    )
    at = st.tuples(st.just("since"), st.just("="), small, st.just(("const", True)), sub)
    return st.one_of(prop, always, at, sub.map(lambda f: ("not", f)))


@settings(max_examples=800, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.tuples(st.sampled_from(["since", "until"]), st.sampled_from(["<", "<="]),
              st.integers(0, 3).map(Fraction), _pointed(2), _pointed(2)),
    st.lists(st.tuples(st.integers(1, 3), st.sets(st.sampled_from(PROPS))), min_size=1,
             max_size=8),
)  # fmt: skip
def test_windowed_since_and_until_over_isolated_points(formula, steps):
    """`phi since[<T] psi` and `phi until[<T] psi` in one sweep each: where psi holds
    at an isolated point, the window ends exactly T after it (since) or reaches back
    exactly T before it (until), open or closed, and phi's run from it (since) or
    into it (until) decides how far; on traces whose stretches are as long as the
    bounds."""
    times, states, t = [], [], Fraction(0)
    for gap, state in steps:
        times.append(t)
        states.append(frozenset(state))
        t += gap
    trace = Trace(times, states, t)
    assert monitored(formula, trace, trace.end, False) == Reference(trace).segments(formula)


def test_windowed_since_ends_its_window_after_an_isolated_point():
    """`a` on [0, 1) makes `always[<1] a` true at 0 only; with b throughout, `b
    since[<3]` it holds on [0, 3): at 3 the point is 3 back, outside a `<` window."""
    psi = ("not", ("until", "<", 1, ("const", True), ("not", ("prop", "a"))))
    formula = ("since", "<", 3, ("prop", "b"), psi)
    trace = Trace([Fraction(0), Fraction(1)], [frozenset("ab"), frozenset("b")], Fraction(12))
    got = monitored(formula, trace, trace.end, False)
    assert got == Reference(trace).segments(formula)
    assert got[0][:4] == (0, 3, True, False)


@pytest.mark.parametrize("read_between", [False, True])
def test_once_exactly_shifts_a_pulse_whatever_the_updates(read_between):
    """`once[=2] a` over a pulse of a at 3 is true at 5 alone, whether or not the
    verdicts are read (and the monitor updated) at 5 itself: the shifted point is
    then where an update starts."""
    monitor = Monitor(("since", "=", 2, ("const", True), ("prop", "a")))
    monitor.step(0, set())
    monitor.step(3, set(), {"a"})
    monitor.step(5, set())
    if read_between:
        list(monitor.verdicts())
    monitor.step(7, set())
    monitor.end(10)
    true = [s[:4] for s in merge(monitor.verdicts()) if s[4] == "true"]
    assert true == [(5, 5, True, True)]


def test_a_window_that_starts_at_the_origin_is_open_there():
    """Found by the C target's random cases: `a since[<4] b` over a pulse of b at the
    first instant, a throughout, holds on [0, 4): at 4 the pulse is 4 back, outside a
    `<` window, although the window starts at the origin (the pointwise evaluation
    took such a window as closed)."""
    from rmvdsl.runtime import rmtld3

    def run() -> list:
        monitor = Monitor(("since", "<", 4, ("prop", "a"), ("prop", "b")))
        monitor.step(0, {"a"}, {"b"})
        monitor.step(8, {"a"})
        monitor.end(10)
        return merge(monitor.verdicts())

    swept = run()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rmtld3.Temporal, "update", rmtld3.Evaluated.update)
        assert run() == swept
    assert swept[0] == (0, 4, True, False, "true")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.one_of(
        st.tuples(st.just("since"), st.sampled_from(["<", "<="]), st.integers(1, 4).map(Fraction),
                  _pointed(0), _pointed(0)),
        st.tuples(st.just("since"), st.sampled_from(["<", "<="]), st.integers(1, 4).map(Fraction),
                  _pointed(2), _pointed(2)),
        windows(3),
    ),
    st.lists(st.tuples(st.integers(1, 3), st.sets(st.sampled_from(PROPS))), min_size=1,
             max_size=10),
)  # fmt: skip
def test_verdicts_read_after_every_sample_equal_the_reference(formula, steps):
    """Reading the verdicts after every sample updates the monitor from each
    sample's time: a `since` with a window then starts each update from what it
    carried over (the latest witness before the sample), never from the window's
    start."""
    monitor, segments, times, states, t = Monitor(formula), [], [], [], Fraction(0)
    for gap, state in steps:
        times.append(t)
        states.append(frozenset(state))
        monitor.step(t, state)
        segments += monitor.verdicts()
        t += gap
    monitor.end(t)
    segments += monitor.verdicts()
    assert merge(segments) == Reference(Trace(times, states, t)).segments(formula)


def test_a_witness_just_before_an_update_ends_a_closed_window_open():
    """b holds on [0, 1): read after every sample, `a since[<=2] b` is updated from 1
    with its latest witness carried over, b just before 1, never at 1 itself: true
    on [0, 3), false at 3."""
    monitor, segments = Monitor(("since", "<=", 2, ("prop", "a"), ("prop", "b"))), []
    for t, state in ((0, "ab"), (1, "a"), (2, "a"), (5, "")):
        monitor.step(t, set(state))
        segments += monitor.verdicts()
    monitor.end(6)
    segments += monitor.verdicts()
    assert merge(segments) == [(0, 3, True, False, "true"), (3, 6, True, False, "false")]


def test_a_witness_is_not_carried_over_a_point_where_phi_fails():
    """phi (`not always[<1] c`, c on [1, 2)) fails at 1 alone: b on [0, 1) is then no
    witness for any later time, whichever update carries it over."""
    always = ("not", ("until", "<", 1, ("const", True), ("not", ("prop", "c"))))
    formula = ("since", "<=", 5, ("not", always), ("prop", "b"))
    samples = [(0, "b"), (1, "c"), (2, ""), (3, ""), (4, "a"), (5, "")]
    monitor, segments = Monitor(formula), []
    for t, state in samples:
        monitor.step(t, set(state))
        segments += monitor.verdicts()
    monitor.end(8)
    segments += monitor.verdicts()
    times = [Fraction(t) for t, _ in samples]
    trace = Trace(times, [frozenset(s) for _, s in samples], Fraction(8))
    assert merge(segments) == Reference(trace).segments(formula)
    assert merge(segments) == [(0, 1, True, False, "true"), (1, 8, True, False, "false")]


def nested_windows(depth: int = 4) -> st.SearchStrategy:
    """Windows of one kind directly inside one another (`eventually` in
    `eventually`, `always` in `always`, and the past ones), any op, bounds short
    enough that the windows' ends fall inside the traces, around random formulas."""
    sub = formulas(2) if depth == 0 else nested_windows(depth - 1)
    true = ("const", True)

    def window(tag: str, op: str, bound: Fraction, body: tuple, negated: bool) -> tuple:
        if negated:  # always / historically
            return ("not", (tag, op, bound, true, ("not", body)))
        return (tag, op, bound, true, body)

    def chain(tag: str, negated: bool, ops: list[str], bounds: list[Fraction], body: tuple):
        for op, bound in zip(ops, bounds, strict=False):
            body = window(tag, op, bound, body, negated)
        return body

    kinds = st.sampled_from(["until", "since"])
    small = st.integers(0, 4).map(Fraction)  # windows that end inside the traces
    return st.one_of(
        sub,
        st.builds(window, kinds, OPS, small, sub, st.booleans()),
        st.builds(
            chain,
            kinds,
            st.booleans(),
            st.lists(OPS, min_size=2, max_size=4),
            st.lists(small, min_size=2, max_size=4),
            sub,
        ),
    )


_P, _TRUE = ("prop", "a"), ("const", True)
_TIMES = [Fraction(0), Fraction(2), Fraction(3)]
_STEP = Trace(_TIMES, [frozenset(), frozenset({"a"}), frozenset()], Fraction(6))


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(nested_windows(), traces(), st.data())
@example(("until", "<", Fraction(0), _TRUE, ("until", "<=", Fraction(1), _TRUE, _P)), _STEP, None)
@example(("until", "<", Fraction(1), _TRUE, ("until", "<", Fraction(1), _TRUE, _P)), _STEP, None)
@example(("since", "<=", Fraction(1), _TRUE, ("since", "<", Fraction(2), _TRUE, _P)), _STEP, None)
@example(["until", "<=", Fraction(1), ["const", True], ["until", "<", Fraction(2), _TRUE, _P]],
         _STEP, None)  # lists, as a host keeps formulas  # fmt: skip
def test_merged_windows_give_the_verdicts_of_the_nested_ones(formula, trace, data):
    """The solver's questions and the monitors take formulas whose nested windows
    of one kind are merged (rmvdsl.runtime.nesting): on any trace, cut anywhere
    (three-valued verdicts), the reference evaluator gives the same verdicts for
    both, and the monitor (which merges) those of the formula as written."""
    from rmvdsl.runtime.nesting import flattened

    merged = flattened(formula)
    cut = trace.end / 2 if data is None else data.draw(st.integers(1, int(trace.end)).map(Fraction))
    kept = [(t, s) for t, s in zip(trace.times, trace.states, strict=True) if t < cut]
    cut_trace = Trace([t for t, _ in kept], [s for _, s in kept], cut)
    for part in (cut_trace, trace):
        written = Reference(part).segments(formula)
        assert Reference(part).segments(merged) == written
        assert monitored(formula, part, part.end, False) == written
    if "until" in str(formula) or "since" in str(formula):
        assert len(str(merged)) <= len(str(formula))


def terms(depth: int = 2) -> st.SearchStrategy:
    """Terms of durations and constants: sums, differences and products with a
    constant factor on either side (`2 * duration(...)`, `duration(...) * 3`)."""
    duration = st.tuples(st.just("dur"), BOUNDS.filter(lambda b: b > 0), formulas(2))
    number = st.integers(0, 10).map(lambda n: ("num", Fraction(n)))
    if depth == 0:
        return st.one_of(duration, number)
    sub = terms(depth - 1)
    return st.one_of(
        duration,
        number,
        st.tuples(st.sampled_from(["add", "sub"]), sub, sub),
        st.tuples(st.just("mul"), number, sub),
        st.tuples(st.just("mul"), sub.filter(lambda t: t[0] != "num"), number),
    )


def _with_terms() -> st.SearchStrategy:
    compared = st.tuples(
        st.just("cmp"), st.sampled_from(["<", "<=", ">", ">=", "==", "!="]), terms(), terms()
    )
    return st.one_of(formulas(3), compared, st.tuples(st.just("and"), formulas(3), compared))


_ONE_SECOND_OF_A = Trace([Fraction(0), Fraction(1)], [frozenset("a"), frozenset()], Fraction(6))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_with_terms(), traces(), st.booleans())
@example(("cmp", "<", ("mul", ("num", 2), ("dur", 4, ("prop", "a"))), ("num", 3)),
         _ONE_SECOND_OF_A, False)  # fmt: skip
@example(("cmp", ">", ("mul", ("dur", 4, ("prop", "a")), ("num", 3)), ("num", 2)),
         _ONE_SECOND_OF_A, True)  # fmt: skip
@example(("cmp", "<", ("mul", ("num", 2), ("num", 3)), ("dur", 9, ("prop", "a"))),
         _ONE_SECOND_OF_A, False)  # fmt: skip
def test_a_formula_scaled_to_nanoseconds_gives_the_verdicts_in_seconds(formula, trace, one_by_one):
    """The runtime feeds its monitors integer nanoseconds and the formula with its
    times scaled alike (rmvdsl.runtime.formulas.scaled): its verdicts, turned back
    into seconds, are the formula's over the trace in seconds."""
    ns = 10**9
    expected = monitored(formula, trace, trace.end, one_by_one)
    in_ns = Trace([int(t * ns) for t in trace.times], trace.states, int(trace.end * ns))
    got = monitored(scaled(formula, ns), in_ns, in_ns.end, one_by_one)
    assert [(Fraction(a, ns), Fraction(b, ns), *rest) for a, b, *rest in got] == expected


@st.composite
def unions(draw: st.DrawFn) -> list[list]:
    """Intervals added in order to a union, as the sweeps add them (ends ordered)."""
    from rmvdsl.runtime.covers import add

    intervals: list[list] = []
    low = Fraction(draw(st.integers(-6, 6)), 2)
    for _ in range(draw(st.integers(0, 6))):
        low += Fraction(draw(st.integers(0, 4)), 2)
        high = low + Fraction(draw(st.integers(0, 4)), 2)
        closed = draw(st.booleans()), draw(st.booleans())
        if high == low and not all(closed):
            continue  # an empty interval
        if draw(st.integers(0, 9)) == 0:
            high, closed = float("inf"), (closed[0], False)
        add(intervals, low, closed[0], high, closed[1])
        low = max(low, high if high != float("inf") else low)
    return intervals


@settings(max_examples=400, deadline=None)
@given(one=unions(), two=unions(), start=st.integers(-8, 8).map(lambda k: Fraction(k, 2)))
def test_a_sweep_writes_how_many_of_its_unions_cover_each_time(one, two, start):
    """`write` reads each union as a step function: at every time from `start` on
    (every end, and between two ends) the signal is the number of unions that hold
    it, checked against membership one interval at a time."""
    from rmvdsl.runtime.covers import write
    from rmvdsl.runtime.signal import Signal

    def holds(intervals: list[list], t: Fraction) -> int:
        return int(any((lo < t or (lo == t and lc)) and (t < hi or (t == hi and hc))
                       for lo, lc, hi, hc in intervals))  # fmt: skip

    signal = Signal(start - 1, 0)
    write(signal, start, (one, two))
    ends = sorted({start, *(e for i in one + two for e in (i[0], i[2]) if start < e < 99)})
    probes = [*ends, *((a + b) / 2 for a, b in itertools.pairwise(ends)), ends[-1] + 1]
    for t in probes:
        assert signal.at(t) == holds(one, t) + holds(two, t), (t, one, two)
