"""`rmv eval`: one formula over one trace file, with the online monitor."""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from rmvdsl.grammar.formula import Formula, Term
from rmvdsl.grammar.formula_parser import parse_formula
from rmvdsl.lang.diagnostics import Diagnostic, Severity, error
from rmvdsl.lang.numbers import to_json
from rmvdsl.logic.compile import CompileError, compile_formula
from rmvdsl.logic.trace_chunks import SCALE, scaled
from rmvdsl.logic.trace_lines import TraceFile
from rmvdsl.logic.traces import Change, TraceStream
from rmvdsl.logic.validate import check_formula
from rmvdsl.runtime.facts import facts
from rmvdsl.runtime.rmtld3 import BATCH, Monitor, Segment, merge, merged
from rmvdsl.runtime.values import exact_text
from rmvdsl.runtime.wording import counted
from rmvdsl.util.batched import Batched


@dataclass
class Evaluation:
    segments: list[Segment] = field(default_factory=list)
    beyond: list[Segment] = field(default_factory=list)  # after the trace's end
    memory: int = 0  # breakpoints held at the end
    horizon: Fraction = Fraction(0)  # ahead plus back, in trace units
    nodes: int = 0  # lists kept: one per subformula, two for a `since` (Monitor.lists)

    def bound(self) -> str:
        """The static memory bound (docs/semantics.md)."""
        return (
            f"at most {counted(self.nodes, 'list')} x "
            f"(2 x (horizon {exact_text(self.horizon)} + 1)"
            f" x state changes per time unit + {BATCH + 3}) breakpoints"
        )


def parse(text: str, syntax: str, term: bool) -> tuple[Formula | Term | None, list[Diagnostic]]:
    return parse_formula(text, syntax, "<formula>", "term" if term else "formula")


def compile_or_diagnose(
    node: Any,
    unit: Fraction = Fraction(1),
    default_unit: str = "s",
    found: list[Diagnostic] | None = None,
    text: str | None = None,
) -> tuple[Any, list[Diagnostic]]:
    """The runtime form of a parsed formula, or why there is none. `unit`: one time
    unit of the trace in seconds; `default_unit`: the unit of bare numbers; `found`:
    what parsing it said; `text`: the formula's text. The checks are those a spec's
    property gets (rmvdsl.logic.validate)."""
    problems = [*(found or []), *check_formula(node, default_unit, text)]
    if any(d.severity is Severity.ERROR for d in problems):
        return None, problems
    try:
        return compile_formula(node, unit, default_unit), []
    except CompileError as exc:
        span = getattr(exc.node, "span", None)
        code = "RMV212" if "needs a time bound" in str(exc) else "RMV219"
        return None, [error(code, str(exc), span, label="here")]  # type: ignore[arg-type]


def run(formula: Any, trace: TraceFile) -> Evaluation:
    """A whole trace in memory (times in its unit), every segment kept."""
    monitor = Monitor(formula)
    monitor.feed(zip(trace.times, trace.states, strict=True))
    assert trace.end is not None
    monitor.end(trace.end)
    return Evaluation(
        merge(monitor.verdicts()),
        monitor.beyond(),
        monitor.memory(),
        Fraction(monitor.horizon),
        monitor.lists(),
    )


class Streamed:
    """A formula compiled for a stream's scale (`compile_or_diagnose` with
    `trace.unit_seconds / SCALE`) over a trace read as it goes: `segments()` yields
    the merged verdict segments, in the trace's unit, as they are decided; after it,
    `summary` holds what comes after the end and what the monitor held."""

    BLOCK = 4096  # change points fed between two readings of the verdicts

    def __init__(self, formula: Any, trace: TraceStream) -> None:
        self.monitor = Monitor(formula)
        self.trace = trace
        self.summary = Evaluation()

    def segments(self) -> Iterator[Segment]:
        return map(_unscaled, self.scaled_segments())

    def scaled_segments(self) -> Iterator[Segment]:
        """The merged segments, their times in billionths of the trace's unit."""
        return merged(self._decided())

    def _decided(self) -> Iterator[Segment]:
        monitor, changes = self.monitor, self.trace.changes()
        while block := list(itertools.islice(changes, self.BLOCK)):
            monitor.feed(block)
            yield from monitor.verdicts()
        assert self.trace.end is not None
        monitor.end(scaled(self.trace.end))
        yield from monitor.verdicts()
        self.summary = Evaluation(
            [],
            [_unscaled(s) for s in monitor.beyond()],
            monitor.memory(),
            Fraction(monitor.horizon) / SCALE,
            monitor.lists(),
        )


def _unscaled(segment: Segment) -> Segment:
    a, b, a_closed, b_closed, value = segment
    return _time_of(a), _time_of(b), a_closed, b_closed, value


def _time_of(value: Any) -> Any:
    """A stream time back in the trace's unit (infinity stays)."""
    return value if isinstance(value, float) and math.isinf(value) else Fraction(value) / SCALE


def write_all_json(out: Batched, run: Streamed) -> None:
    """`rmv eval --all --format json`, written as the segments come: the same text
    as `as_json` of the whole payload, never all of it in memory."""
    out.write('{\n  "segments": [')
    count = 0
    for count, (a, b, a_closed, b_closed, value) in enumerate(run.scaled_segments(), 1):
        item = _SEGMENT_JSON % (
            _scaled_json(a), _scaled_json(b), _BOOLEANS[a_closed], _BOOLEANS[b_closed],
            json.dumps(value),
        )  # fmt: skip
        out.write(("," if count > 1 else "") + item)
    out.write("\n  ]" if count else "]")
    summary = run.summary
    rest = to_json(
        {
            "beyond": [segment_json(s) for s in summary.beyond],
            "horizon": summary.horizon,
            "memory": {"held": summary.memory, "bound": summary.bound()},
        }
    )
    out.write(",\n" + rest.removeprefix("{\n") + "\n")


# A segment as `to_json(segment_json(...))` writes it, indented under "segments":
# written directly (json.dumps of each segment's dict was a third of the monitor's
# and the output's instructions on bench_eval's trace).
_SEGMENT_JSON = """
    {
      "from": %s,
      "to": %s,
      "from_closed": %s,
      "to_closed": %s,
      "verdict": %s
    }"""
_BOOLEANS = {True: "true", False: "false"}


def _scaled_json(value: Any) -> str:
    """A stream time (billionths) as JSON, as `to_json(json_time(...))` writes it
    back in the trace's unit: the exact decimal, a quotient string, or null."""
    if type(value) is not int:
        return to_json(json_time(_time_of(value)))
    return exact_text(Fraction(value, SCALE))  # billionths: always a decimal


def reference_verdict(formula: Any, trace: TraceFile, t: Fraction) -> str:
    """The verdict at t by the reference evaluator (docs/semantics.md)."""
    from rmvdsl.logic.reference import Reference, Trace
    from rmvdsl.runtime.rmtld3 import NAMES

    assert trace.end is not None
    return NAMES[Reference(Trace(trace.times, trace.states, trace.end)).value(formula, t)]


def reference_part(
    stream: TraceStream, changes: Iterator[Change], t: Fraction, f: Any
) -> TraceFile:
    """The part of the trace the reference evaluator reads for the value of `f` (a
    formula or a term) at t, from the stream's changes: from a past horizon before
    t (from the start under an unbounded `since`) to the first change past the
    future horizon after t. Read whole, a trace of a million samples took the
    reference evaluator a minute; the part is a few horizons long, whatever the
    trace's length: its first change is the last one at or before the past
    horizon, which no value at t reads before (docs/semantics.md, "horizon").
    `changes` is left after the first change it did not take."""
    found = facts(f)
    low, high = t - found.past, t + found.future  # low: -inf under an unbounded since
    trace = TraceFile(unit=stream.unit)
    times, states = trace.times, trace.states
    for time, state in changes:
        at = _time_of(time)
        if at > high and times:  # (the first sample is kept: it is where time starts)
            trace.end = at  # the state before it holds up to it
            break
        if at <= low:  # the latest change at or before `low` holds at `low`
            times[:], states[:] = [at], [state]
        else:
            times.append(at)
            states.append(state)
    else:
        trace.end = Fraction(stream.end) if stream.end is not None else None
    return trace


def term_at(term: Any, trace: TraceFile, t: Fraction) -> tuple[Fraction, Fraction]:
    """The value of a term at t (exact): an interval where the trace does not
    decide it."""
    from rmvdsl.logic.reference import Reference, Trace

    assert trace.end is not None
    return Reference(Trace(trace.times, trace.states, trace.end)).term(term, t)


def _time_text(value: Any) -> str:
    return "inf" if isinstance(value, float) and math.isinf(value) else exact_text(Fraction(value))


def segment_text(segment: Segment, time_text: Callable[[Any], str] = _time_text) -> str:
    """A segment's line: its times in the trace's unit (`scaled_text` for a stream's
    segments, in billionths of it)."""
    a, b, a_closed, b_closed, value = segment
    if a == b:
        return f"{time_text(a)}  {value}"
    left, right = "[" if a_closed else "(", "]" if b_closed else ")"
    return f"{left}{time_text(a)}, {time_text(b)}{right}  {value}"


def scaled_text(value: Any) -> str:
    """A stream time (billionths) as `_time_text` writes it back in the trace's unit,
    through one fraction (`_time_of` and `_time_text` made three: half of `rmv eval
    --all`'s time on a trace whose every sample changes the verdict)."""
    if type(value) is int:
        return exact_text(Fraction(value, SCALE))  # billionths: always a decimal
    return _time_text(_time_of(value))


def segment_json(segment: Segment) -> dict[str, Any]:
    a, b, a_closed, b_closed, value = segment
    return {
        "from": json_time(a),
        "to": json_time(b),
        "from_closed": a_closed,
        "to_closed": b_closed,
        "verdict": value,
    }


def json_time(value: Any) -> Fraction | None:
    """A time for JSON, exact (None for a segment that never ends)."""
    if isinstance(value, float) and math.isinf(value):
        return None
    return Fraction(value)


def as_json(payload: dict[str, Any]) -> str:
    return to_json(payload) + "\n"
