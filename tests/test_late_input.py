"""Late input makes verdicts unknown, never wrong (docs/runtime.md, "Late input").

A message later than the spec's lateness is dropped; the properties reading its
topic are unknown where their verdicts read the stretch it would have changed. The
random test is the definition: wherever a run that dropped messages says true or
false, the run that got every message in order says the same.
"""

from __future__ import annotations

import random
from fractions import Fraction

import pytest

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime.engine import Runtime
from rmvdsl.runtime.uncertain import Uncertain
from rmvdsl.tools.report.text import text_line

F = Fraction
HEAD = """system late
topic t: std_msgs/msg/Float64 = "/t"
topic u: std_msgs/msg/Float64 = "/u"
var x = t.data
var y = u.data
event High when x > 5
event Busy when y > 5
event MeanX = mean(x)
    group by time(500ms)
event HotMean when MeanX > 5
"""


def _spec(tmp_path, body):
    path = tmp_path / "late.rmv"
    path.write_text(HEAD + body, encoding="utf-8")
    return lower(check(str(path)))


def _run(spec, messages, decide=False):
    """`messages`: (seconds, topic, value) in arrival order."""
    runtime = Runtime(spec)
    records = []
    for seconds, topic, value in messages:
        runtime.message(int(F(seconds) * 10**9), topic, {"data": value})
        if decide:
            runtime.decide()
            records += runtime.records()
    runtime.end()
    return records + runtime.records()


def _verdicts(records, name="P"):
    return [
        (r["verdict"], r["from"], r["to"], r["bounds"], r.get("revised", False))
        for r in records if r["kind"] == "verdict" and r["property"] == name
    ]  # fmt: skip


def test_a_segment_crossing_an_interval_is_unknown_inside_it_only():
    uncertain = Uncertain()
    uncertain.add(F(2), F(3))
    assert uncertain.mask((F(0), F(5), True, False, "true")) == [
        (0, 2, True, False, "true"), (2, 3, True, True, "unknown"), (3, 5, False, False, "true"),
    ]  # fmt: skip
    assert uncertain.mask((F(3), F(4), False, False, "false")) == [(3, 4, False, False, "false")]
    assert uncertain.intervals == []  # passed: forgotten


def test_an_interval_with_no_end_yet_covers_everything_after_it():
    uncertain = Uncertain()
    interval = uncertain.add(F(1), None)
    assert uncertain.mask((F(0), F(9), True, True, "false")) == [
        (0, 1, True, False, "false"), (1, 9, True, True, "unknown"),
    ]  # fmt: skip
    interval[1] = F(10)
    assert uncertain.mask((F(10), F(12), False, True, "false")) == [(10, 12, False, True, "false")]


def test_the_dropped_stretch_is_unknown(tmp_path):
    spec = _spec(tmp_path, "property P: not High {\n    lateness = 500ms\n}\n")
    arrivals = [("0", "/t", 1.0), ("1", "/t", 7.0), ("1.5", "/t", 1.0), ("0.5", "/t", 1.0)]
    assert _verdicts(_run(spec, arrivals)) == [
        ("true", 0, F("0.5"), "[)", False),
        ("unknown", F("0.5"), 1, "[]", False),
        ("false", 1, F("1.5"), "()", False),
    ]


def test_verdicts_already_given_out_are_revised(tmp_path):
    spec = _spec(tmp_path, "property P: not High {\n    lateness = 500ms\n}\n")
    arrivals = [("0", "/t", 1.0), ("1", "/t", 7.0), ("1.5", "/t", 1.0), ("2.5", "/t", 1.0),
                ("1.2", "/t", 7.0), ("3", "/t", 1.0)]  # fmt: skip
    verdicts = _verdicts(_run(spec, arrivals, decide=True))
    assert verdicts == [
        ("true", 0, 1, "[)", False),
        ("false", 1, F("1.5"), "[)", False),
        ("unknown", F("1.2"), F("1.5"), "[]", True),
        ("true", F("1.5"), 3, "()", False),
    ]
    record = {"kind": "verdict", "property": "P", "verdict": "unknown", "from": F("1.2"),
              "to": F("1.5"), "bounds": "[]", "revised": True}  # fmt: skip
    assert text_line(record) == "verdict   P: unknown on [1.2, 1.5] (revised: late input)"


def test_a_property_that_does_not_read_the_topic_keeps_its_verdicts(tmp_path):
    body = "property P: not High {\n    lateness = 500ms\n}\nproperty Q: not Busy\n"
    spec = _spec(tmp_path, body)
    arrivals = [("0", "/t", 1.0), ("0", "/u", 1.0), ("1", "/u", 7.0), ("2", "/u", 1.0),
                ("0.5", "/u", 9.0)]  # fmt: skip
    records = _run(spec, arrivals)
    assert _verdicts(records, "P") == [("true", 0, 2, "[)", False)]
    assert ("unknown", F("0.5"), 1, "[]", False) in _verdicts(records, "Q")


def test_a_topic_silent_since_the_late_message_is_unknown_until_it_publishes(tmp_path):
    spec = _spec(tmp_path, "property P: not High {\n    lateness = 500ms\n}\n")
    arrivals = [("0", "/t", 1.0), ("1", "/u", 1.0), ("2", "/u", 1.0), ("0.5", "/t", 9.0),
                ("3", "/u", 1.0), ("4", "/t", 1.0), ("5", "/u", 1.0)]  # fmt: skip
    assert _verdicts(_run(spec, arrivals)) == [
        ("true", 0, F("0.5"), "[)", False),
        ("unknown", F("0.5"), 4, "[]", False),
        ("true", 4, 5, "()", False),
    ]


def test_a_window_widens_the_stretch_by_its_interval(tmp_path):
    spec = _spec(tmp_path, "property P: not HotMean {\n    lateness = 500ms\n}\n")
    arrivals = [(str(F(k, 2)), "/t", 1.0) for k in range(0, 13)]
    in_order = sorted([*arrivals, ("3.2", "/t", 50.0)], key=lambda m: F(m[0]))
    assert _verdicts(_run(spec, in_order)) == [
        ("true", 0, 3, "[)", False), ("false", 3, F("3.5"), "[)", False),
        ("true", F("3.5"), 6, "[)", False),
    ]  # fmt: skip
    arrivals.insert(9, ("3.2", "/t", 50.0))  # after 4 came: dropped when 3.5 was fed
    # The window [3, 3.5) would have held it: unknown from 2.7 (3.2 less one
    # interval) to 4 (3.5, the newest fed, plus one).
    assert _verdicts(_run(spec, arrivals)) == [
        ("true", 0, F("2.7"), "[)", False), ("unknown", F("2.7"), 4, "[]", False),
        ("true", 4, 6, "()", False),
    ]  # fmt: skip


# ---- the definition, over random traces ----

FORMULAS = (
    "not High",
    "High -> eventually[<=1s] Busy",
    "once[<=700ms] High or not Busy",
    "duration[1s](High) < 600ms",
    "not Busy until[<2s] High",
    "not HotMean or Busy",
)


def _verdict_at(records, name, time):
    """The last record covering `time` (a revision overrides what came before)."""
    found = None
    for r in records:
        if r["kind"] != "verdict" or r["property"] != name:
            continue
        low, high = r["from"], r["to"]
        inside_low = time > low or (time == low and r["bounds"][0] == "[")
        inside_high = time < high or (time == high and r["bounds"][1] == "]")
        if inside_low and inside_high:
            found = r["verdict"]
    return found


@pytest.mark.parametrize("seed", range(40))
def test_late_input_makes_verdicts_unknown_never_wrong(tmp_path, seed):
    chance = random.Random(seed)
    formula = FORMULAS[seed % len(FORMULAS)]
    rate = "\n    rate = 10Hz" if seed % 3 == 0 else ""
    spec = _spec(tmp_path, f"property P: {formula} {{\n    lateness = 200ms{rate}\n}}\n")
    times = sorted({F(chance.randrange(0, 60), 10) for _ in range(40)})
    messages = [(t, chance.choice(("/t", "/u")), float(chance.choice((1, 9)))) for t in times]
    in_order = _run(spec, messages)
    arrivals = list(messages)
    for _ in range(chance.randrange(1, 5)):  # a message arrives long after its time
        k = chance.randrange(1, len(arrivals) - 1)
        late = arrivals.pop(k)
        arrivals.insert(min(len(arrivals), k + chance.randrange(4, 12)), late)
    dropped = _run(spec, arrivals, decide=seed % 2 == 0)
    probes = sorted({t for t, _, _ in messages} | {t + F(1, 20) for t, _, _ in messages})
    for time in probes:
        said = _verdict_at(dropped, "P", time)
        if said in ("true", "false"):
            assert said == _verdict_at(in_order, "P", time), (formula, time, arrivals)


def _at(records, name="P"):
    """The verdict segments as (verdict, from, to) in seconds."""
    return [(v, f, t) for v, f, t, _, _ in _verdicts(records, name)]


def test_lost_and_damaged_input_is_unknown_where_it_was():
    """Lost messages (a gap the host saw before the message at 5 s) leave the topic
    unknown since its last message; a damaged one at 7 s until the next, at 8 s.
    `P: not High` is decided everywhere else; x is never high."""
    spec = _spec_text("property P: not High\n")
    runtime = Runtime(spec)
    for second in range(10):
        at = second * 10**9
        if second == 5:
            runtime.lost(at, "/t", 2)
        if second == 7:
            runtime.damaged(at, "/t", "3 bytes short")
            continue
        runtime.message(at, "/t", {"data": 1.0})
    runtime.end()
    records = runtime.records()
    assert _at(records) == [("true", 0, 4), ("unknown", 4, 5), ("true", 5, 7),
                            ("unknown", 7, 8), ("true", 8, 9)]  # fmt: skip
    counters = {r["name"]: r["value"] for r in records if r["kind"] == "counter"}
    assert counters["lost messages: /t"] == 2 and counters["damaged messages: /t"] == 1


def test_a_stamp_far_ahead_of_its_receipt_is_dropped_not_believed():
    """A message stamped a year ahead would make every later message late: it is
    dropped and counted; its topic is unknown from the message before it (its time
    is a stamp: the receipt time is another clock) to the one after, which is on
    time."""
    spec = _spec_text("property P: not High\n", stamped=True)
    runtime = Runtime(spec)
    year = 365 * 86_400 * 10**9
    for second in range(6):
        at = second * 10**9
        stamp = at + year if second == 2 else at
        runtime.message(at, "/t", _stamped(stamp, 1.0))
    runtime.end()
    records = runtime.records()
    assert _at(records) == [("true", 0, 1), ("unknown", 1, 3), ("true", 3, 5)]
    counters = {r["name"]: r["value"] for r in records if r["kind"] == "counter"}
    assert counters["messages stamped ahead dropped: /t"] == 1
    assert not [name for name in counters if name.startswith("late")]
    [said] = [r["message"] for r in records if r["kind"] == "diagnostic"]
    assert said == ("/t: a message stamped 31536000 s ahead of its receipt: dropped (a stamp "
                    "more than 10 s ahead is not believed)")  # fmt: skip


def _spec_text(body, stamped=False):
    topic = 'topic t: geometry_msgs/TwistStamped = "/t" qos { time = header }\n'
    text = (
        "system lost\n" + (topic if stamped else 'topic t: std_msgs/msg/Float64 = "/t"\n')
        + ("var x = t.twist.linear.x\n" if stamped else "var x = t.data\n")
        + "event High when x > 5\n" + body
    )  # fmt: skip
    return lower(check("lost.rmv", text, use_environment=False))


def _stamped(nanoseconds, value):
    stamp = {"sec": nanoseconds // 10**9, "nanosec": nanoseconds % 10**9}
    return {"header": {"stamp": stamp}, "twist": {"linear": {"x": value}}}
