"""A duration read from a signal's integral equals the same duration walked over the
window, exactly, for every kind of time the monitor computes with."""

from __future__ import annotations

from fractions import Fraction

from hypothesis import given, settings
from hypothesis import strategies as st

from rmvdsl.runtime.durations import Integral, duration
from rmvdsl.runtime.signal import FALSE, TRUE, UNKNOWN, Signal

VALUES = st.sampled_from([FALSE, UNKNOWN, TRUE])
# The monitor's times are ints (whole billionths) with exact half-integer floats
# between them (_mid), or Fractions throughout: never a float beside a Fraction.
INTEGER_TIMES = st.one_of(st.integers(-50, 400), st.integers(-100, 800).map(lambda n: n / 2))
FRACTION_TIMES = st.fractions(Fraction(-50), Fraction(400), max_denominator=7)


@st.composite
def signals(draw: st.DrawFn) -> Signal:
    signal = Signal(draw(st.integers(-20, 20)), draw(VALUES))
    for step in draw(st.lists(st.integers(1, 40), max_size=30)):
        signal.append(signal.starts[-1] + step, draw(VALUES), draw(VALUES))
    return signal


@settings(max_examples=500, deadline=None)
@given(
    signal=signals(),
    window=st.one_of(
        st.tuples(INTEGER_TIMES, st.integers(0, 300)),
        st.tuples(FRACTION_TIMES, st.fractions(Fraction(0), Fraction(300), max_denominator=5)),
    ),
)
def test_the_integral_reads_what_the_walk_reads(signal, window):
    low, width = window
    assert Integral(signal).duration(low, low + width) == duration(signal, low, low + width)
