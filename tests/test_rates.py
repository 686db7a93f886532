"""A topic's declared `max_rate` (docs/runtime.md, "Declared rates"): the messages
past it are counted and reported once, and still read; in a replay as in a node."""

from __future__ import annotations

import json
from fractions import Fraction

import fleet_recordings
from hypothesis import given
from hypothesis import strategies as st

from rmvdsl.runtime.rates import NS, RateLimit

RATES = st.sampled_from(
    [Fraction(1, 10), Fraction(1, 2), Fraction(1), Fraction(5, 2), Fraction(20)]
)


@given(RATES, st.lists(st.integers(0, 3 * NS), max_size=120))
def test_the_counted_messages_are_exactly_the_excess(hertz, gaps):
    """Against the definition: the messages not counted never hold more than the
    allowance in one window, and each counted one would have made it one more."""
    limit = RateLimit(hertz)
    times = [sum(gaps[: k + 1]) for k in range(len(gaps))]
    kept: list[int] = []
    for time in times:
        within = [t for t in kept if time - t < limit.window_ns]
        assert limit.exceeded(time) == (len(within) >= limit.allowed)
        if len(within) < limit.allowed:
            kept.append(time)


def test_words_say_the_allowance():
    assert RateLimit(Fraction(20)).words() == "20Hz: 20 in any 1 s"
    assert RateLimit(Fraction(5, 2)).words() == "2.5Hz: 3 in any 1 s"
    assert RateLimit(Fraction(1, 10)).words() == "0.1Hz: 1 in any 10 s"


def test_a_replay_counts_a_flood_past_the_declared_rate(rmv, tmp_path):
    """600 messages at 100 Hz on a topic declared at 20 Hz: 80 of each second's 100
    are past it, counted once each and reported once; every message is read."""
    spec = tmp_path / "spec.rmv"
    spec.write_text(fleet_recordings.SPEC.replace(
        '= "/vehicle/twist"', '= "/vehicle/twist" qos {\n    max_rate = 20Hz\n}'
    ), encoding="utf-8")  # fmt: skip
    recording = fleet_recordings.write(
        tmp_path / "flood", "mcap", fleet_recordings.speeds(2, 600), step_ns=NS // 100
    )
    result = rmv("replay", str(spec), str(recording), "--format", "jsonl")
    records = [json.loads(line) for line in result.out.splitlines()]
    counters = {r["name"]: r["value"] for r in records if r["kind"] == "counter"}
    assert counters["messages"] == 600
    assert counters["messages over max_rate: /vehicle/twist"] == 480
    said = [r["message"] for r in records if r["kind"] == "diagnostic"]
    assert said == ["/vehicle/twist: more messages than its max_rate (20Hz: 20 in any 1 s): "
                    "each one past it is counted, and still read"], said  # fmt: skip
    text = rmv("replay", str(spec), str(recording))
    assert "messages over max_rate: /vehicle/twist: 480" in text.out, text.out


def test_a_rate_that_is_not_positive_is_an_error(rmv, tmp_path):
    spec = tmp_path / "spec.rmv"
    spec.write_text(fleet_recordings.SPEC.replace(
        '= "/vehicle/twist"', '= "/vehicle/twist" qos {\n    max_rate = 0Hz\n}'
    ), encoding="utf-8")  # fmt: skip
    result = rmv("check", str(spec))
    assert result.code == 1
    assert "spec.rmv:4:16" in result.out and "expected a positive rate" in result.out, result.out
