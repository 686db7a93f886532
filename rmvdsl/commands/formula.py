"""`rmv eval` and `rmv sat`: one formula, over a trace or on its own."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from fractions import Fraction
from typing import TYPE_CHECKING, Any

from rmvdsl.commands import say, use_color
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK, UsageError
from rmvdsl.util.batched import batched

if TYPE_CHECKING:
    from rmvdsl.lang.diagnostics import Diagnostic
    from rmvdsl.logic.answers import Answer
    from rmvdsl.logic.evaluate import Streamed
    from rmvdsl.logic.traces import TraceStream


def run_eval(args: argparse.Namespace) -> int:
    from rmvdsl.lang.numbers import NumberError, exact_or_quotient
    from rmvdsl.logic import evaluate as ev
    from rmvdsl.logic.trace_chunks import SCALE
    from rmvdsl.util import collection

    try:
        at = exact_or_quotient(args.at)
    except NumberError as exc:
        raise UsageError(f"--at: {exc}") from None
    node, diagnostics = ev.parse(args.formula, args.syntax, args.term)
    if args.term:
        return _eval_term(args, node, diagnostics, at)
    with _trace_stream(args.trace) as trace:
        compiled = None
        if node is not None:
            compiled, diagnostics = ev.compile_or_diagnose(
                node, trace.unit_seconds / SCALE, trace.unit, diagnostics, args.formula
            )
        if compiled is None:
            return _formula_errors(args, diagnostics)
        run = ev.Streamed(compiled, trace)
        with collection.for_streams():
            verdict = _eval_output(args, run, at)  # a bad line raises TraceError: exit 2
    for note in [*trace.notes, *_absent_names(compiled, trace.seen)]:
        say(f"rmv eval: {note}")
    if verdict is None:
        return EXIT_OK
    assert trace.first is not None and node is not None
    if at < trace.first:  # before the first sample: what the definitions say there
        plain, _ = ev.compile_or_diagnose(node, trace.unit_seconds, trace.unit, [], args.formula)
        with _trace_stream(args.trace) as again:  # its start, up to the formula's horizon
            part = ev.reference_part(again, again.changes(), at, plain)
        verdict = ev.reference_verdict(plain, part, at)
    if args.format == "json":
        sys.stdout.write(ev.as_json({"t": at, "verdict": verdict}))
    else:
        say(verdict, sys.stdout)
    return EXIT_OK


def _eval_output(args: argparse.Namespace, run: Streamed, at: Fraction) -> str | None:
    """`--all`: every segment written as it is decided (None); else the verdict at
    `at`, the stream read to its end."""
    from rmvdsl.logic import evaluate as ev
    from rmvdsl.runtime.segments import contains
    from rmvdsl.runtime.values import exact_text

    if args.all:
        with batched(sys.stdout) as out:
            if args.format == "json":
                ev.write_all_json(out, run)
                return None
            # the lines hold times and the formula's names (checked): nothing to draw
            for segment in run.scaled_segments():
                out.write(ev.segment_text(segment, ev.scaled_text) + "\n")
        if run.summary.beyond and run.trace.end is not None:
            end = exact_text(run.trace.end)
            say(f"after the end ({end}), as far as the trace decides:", sys.stdout)
        for segment in run.summary.beyond:
            say(ev.segment_text(segment), sys.stdout)
        return None
    verdict = "unknown"
    for segment in run.segments():  # read to the end: every line is checked
        if contains(segment, at):
            verdict = segment[4]
    for segment in run.summary.beyond:
        if contains(segment, at):
            verdict = segment[4]
    return verdict


@contextlib.contextmanager
def _trace_stream(path: str) -> Iterator[TraceStream]:
    from rmvdsl.lang.errors import unreadable
    from rmvdsl.logic.trace_lines import TraceError
    from rmvdsl.logic.traces import TraceStream

    try:
        handle = open(path, "rb")  # noqa: SIM115 (closed below, after the stream)
    except OSError as exc:
        raise unreadable(path, exc) from None
    with handle:
        try:
            yield TraceStream(path, handle)
        except TraceError as exc:
            raise UsageError(str(exc)) from None


def _eval_term(
    args: argparse.Namespace, node: Any, diagnostics: list[Diagnostic], at: Fraction
) -> int:
    from rmvdsl.logic import evaluate as ev
    from rmvdsl.runtime.values import exact_text

    with _trace_stream(args.trace) as stream:
        compiled = None
        if node is not None:
            compiled, diagnostics = ev.compile_or_diagnose(
                node, stream.unit_seconds, stream.unit, diagnostics, args.formula
            )
        if compiled is None:
            return _formula_errors(args, diagnostics)
        changes = stream.changes()
        trace = ev.reference_part(stream, changes, at, compiled)
        for _ in changes:  # every line checked, as `eval` does
            pass
    for note in [*stream.notes, *_absent_names(compiled, stream.seen)]:
        say(f"rmv eval: {note}")
    low, high = ev.term_at(compiled, trace, at)
    if args.format == "json":
        sys.stdout.write(ev.as_json({"t": at, "low": low, "high": high}))
    elif low == high:
        say(exact_text(low), sys.stdout)
    else:
        say(f"unknown (between {exact_text(low)} and {exact_text(high)})", sys.stdout)
    return EXIT_OK


def _absent_names(compiled: object, seen: set[str]) -> list[str]:
    """Propositions of the formula that no sample of the trace holds: a typo reads as
    `false` everywhere, so say so."""
    from rmvdsl.lang.diagnostics import did_you_mean
    from rmvdsl.runtime.rmtld3 import facts

    notes = []
    for name in sorted(set(facts(compiled).propositions) - seen):
        hint = did_you_mean(name, seen)
        notes.append(f"`{name}` holds in no sample of the trace" + (f" ({hint})" if hint else ""))
    return notes


def run_sat(args: argparse.Namespace) -> int:
    from rmvdsl.logic import evaluate as ev
    from rmvdsl.logic.answers import NO, YES
    from rmvdsl.logic.sat import Limits, satisfiable, valid

    limits = Limits(timeout=args.timeout)
    node, diagnostics = ev.parse(args.formula, args.syntax, False)
    compiled = None
    if node is not None:
        compiled, diagnostics = ev.compile_or_diagnose(node, found=diagnostics, text=args.formula)
    if compiled is None:
        return _formula_errors(args, diagnostics)
    sat = satisfiable([compiled], limits=limits)
    validity = valid(compiled, limits=limits)
    if args.format == "json":
        payload = {
            "sat": sat.value,
            "valid": validity.value,
            "exact": sat.exact and validity.exact,
            "witness": sat.witness.as_json() if sat.value == YES and sat.witness else None,
            "counterexample": (
                validity.witness.as_json() if validity.value == NO and validity.witness else None
            ),
        }
        sys.stdout.write(ev.as_json(payload))
        return EXIT_OK
    say(f"satisfiable: {_answer_text(sat)}", sys.stdout)
    if sat.value == YES and sat.witness:
        say("  witness (the formula is true):", sys.stdout)
        say("\n".join("    " + line for line in sat.witness.timeline()), sys.stdout)
    say(f"valid: {_answer_text(validity)}", sys.stdout)
    if validity.value == NO and validity.witness:
        say("  counterexample (the formula is false):", sys.stdout)
        say("\n".join("    " + line for line in validity.witness.timeline()), sys.stdout)
    return EXIT_OK


def _formula_errors(args: argparse.Namespace, diagnostics: list[Diagnostic]) -> int:
    """What is wrong with a --formula, on standard error."""
    from rmvdsl.lang.render import render_text
    from rmvdsl.lang.source import SourceFile, SourceMap

    sources = SourceMap()
    sources.add(SourceFile("<formula>", args.formula))
    sys.stderr.write(render_text(diagnostics, sources, use_color(args) and sys.stderr.isatty()))
    return EXIT_ERRORS


def _answer_text(answer: Answer) -> str:
    if answer.value == "unknown":
        return f"unknown (bounded: {answer.note})"
    return f"{answer.value} (exact)"
