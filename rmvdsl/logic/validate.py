"""The checks every formula gets, wherever it is written: in a spec's property, in
`rmv sat --formula` or `rmv eval --formula` (one validator, so that the same bound
gets the same answer from every front end)."""

from __future__ import annotations

from rmvdsl.grammar import formula as fm
from rmvdsl.lang.diagnostics import Diagnostic, error
from rmvdsl.lang.source import Span


def check_formula(
    formula: fm.Formula | fm.Term, time_unit: str | None, text: str | None = None
) -> list[Diagnostic]:
    """Bounds present on the future operators (the past ones may go without: they
    read the trace so far, in constant memory), with a unit (or a time unit for bare
    numbers), and positive. `text`: the source the spans point into, to underline
    keywords exactly."""
    found: list[Diagnostic] = []
    for node in fm.walk(formula):
        if isinstance(node, fm.Temporal):
            if node.bound is None and node.op in fm.FUTURE:
                found.append(
                    error(
                        "RMV212",
                        f"`{node.op}` needs a time bound",
                        keyword_span(node, text),
                        label="unbounded",
                        help=f"write e.g. `{node.op}[<=10s]`; only the past operators "
                        "(`since`, `once`, `historically`) may go without",
                    )
                )
            elif node.bound is not None:
                found += check_time(node.bound.value, time_unit)
        elif isinstance(node, fm.Duration):
            found += check_time(node.window, time_unit)
    return found


def check_time(time: fm.TimeValue, time_unit: str | None) -> list[Diagnostic]:
    if time.unit is None and time_unit is None:
        return [
            error(
                "RMV213",
                f"the time `{time.text}` has no unit and the spec declares no time unit",
                time.span,
                label="seconds? milliseconds?",
                help=f"write `{time.text}s`, or declare `time unit s` once for the spec",
            )
        ]
    if time.value <= 0:
        return [
            error(
                "RMV219",
                "a time bound must be positive",
                time.span,
                label=f"`{time.text}` is not positive",
            )
        ]
    return []


def keyword_span(node: fm.Temporal, text: str | None = None) -> Span:
    """The operator's keyword (`until`, `eventually`), without the blanks around it."""
    span = node.span
    start = node.left.span.end if node.left is not None else span.start
    end = node.right.span.start
    if node.bound is not None:
        end = min(end, node.bound.span.start) if node.bound.span.path else end
    if text is not None and 0 <= start <= end <= len(text):
        while start < end and (text[start].isspace() or text[start] == ")"):
            start += 1
        word = start
        while word < end and (text[word].isalnum() or text[word] in "_\\"):
            word += 1
        if word > start:
            end = word
    return Span(span.path, start, end)
