"""The AST builder's base: one parse's state per thread, spans from tokens, and the
literals formulas read (numbers with units, times). No declaration's node: a formula
parsed on its own (`rmv eval`) loads none of them (rmvdsl.grammar.build_literals)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from fractions import Fraction
from typing import Any

from lark import Token, Transformer

from rmvdsl.grammar import formula as fm
from rmvdsl.grammar.quantities import QUANTITY, RATE_UNITS, TIME_UNIT_ALIASES
from rmvdsl.lang.diagnostics import Diagnostic, Label, error
from rmvdsl.lang.numbers import NumberError, decimal, exact
from rmvdsl.lang.source import Span

SpanOf = Callable[[Token], Span]


def unescape(raw: str, start: int) -> tuple[str, tuple[int, ...]]:
    """Decode a string literal (with its quotes) found at offset `start`.

    Only `\\"` and `\\\\` are escapes; every other backslash is kept, so LaTeX
    needs none. Returns the value and the file offset of each of its characters.
    """
    chars: list[str] = []
    offsets: list[int] = []
    index = 1
    end = len(raw) - 1
    while index < end:
        char = raw[index]
        if char == "\\" and index + 1 < end and raw[index + 1] in '"\\':
            chars.append(raw[index + 1])
            offsets.append(start + index)
            index += 2
            continue
        chars.append(char)
        offsets.append(start + index)
        index += 1
    return "".join(chars), tuple(offsets)


class _ParseState(threading.local):
    """What one parse writes: each thread has its own (one lark parser, with this
    builder's callbacks, serves every thread)."""

    def __init__(self) -> None:
        self.path = "<input>"
        self.diagnostics: list[Diagnostic] = []
        self.span_of: SpanOf | None = None


class BuilderBase(Transformer[Token, Any]):
    """What every rule callback reads: the parse's state, spans, literals."""

    def __init__(self, path: str = "<input>", span_of: SpanOf | None = None) -> None:
        super().__init__(visit_tokens=False)
        self._state = _ParseState()
        self.path = path
        self._span_of = span_of

    def start_parse(self, path: str, span_of: SpanOf | None = None) -> None:
        """Begin a parse on this thread: its file, and a fresh list of diagnostics."""
        self._state.path = path
        self._state.diagnostics = []
        self._state.span_of = span_of

    @property
    def path(self) -> str:
        return self._state.path

    @path.setter
    def path(self, value: str) -> None:
        self._state.path = value

    @property
    def diagnostics(self) -> list[Diagnostic]:
        return self._state.diagnostics

    @property
    def _span_of(self) -> SpanOf | None:
        return self._state.span_of

    @_span_of.setter
    def _span_of(self, value: SpanOf | None) -> None:
        self._state.span_of = value

    # ---- spans ----

    def span(self, token: Token) -> Span:
        if self._span_of is not None:
            return self._span_of(token)
        return Span(self.path, token.start_pos or 0, token.end_pos or 0)

    def cover(self, items: Sequence[Any]) -> Span:
        first = last = None
        for item in items:
            span = self._item_span(item)
            if span is not None:
                first = first or span
                last = span
        if first is None or last is None:
            return Span(self.path, 0, 0)
        return Span(first.path, first.start, max(first.end, last.end))

    def _item_span(self, item: Any) -> Span | None:
        if item is None:
            return None
        if isinstance(item, Token):
            return self.span(item)
        if isinstance(item, tuple | list):
            return self.cover(item) if item else None
        span = getattr(item, "span", None)
        return span if isinstance(span, Span) and span.path != "<none>" else None

    def duplicate(self, what: str, again: Any, first: Any) -> None:
        self.diagnostics.append(
            error(
                "RMV214",
                f"{what} given more than once",
                again.span,
                label="given again here",
                secondary=[Label(first.span, "first given here")],
                help="keep only one",
            )
        )

    # ---- quantities: numbers, times, rates ----

    def split_quantity(self, token: Token) -> tuple[Fraction, str, str]:
        match = QUANTITY.match(str(token))
        if match is None:  # cannot happen: the lexer's pattern is the same
            return Fraction(0), "", str(token)
        try:
            value = exact(match.group(1))
        except NumberError as exc:
            self.diagnostics.append(
                error("RMV106", str(exc), self.span(token), label="out of range", help=None)
            )
            value = Fraction(0)
        return value, match.group(2), str(token)

    def unknown_unit(self, token: Token, unit: str, expected: str) -> None:
        self.diagnostics.append(
            error(
                "RMV105",
                f"unknown unit `{unit}` in `{token}`",
                self.span(token),
                label=f"expected {expected}",
                help="time units: ns, us, ms, s, m (minutes), h, d, w; rates: Hz",
            )
        )

    def time_value(self, token: Token) -> fm.TimeValue:
        value, unit, text = self.split_quantity(token)
        normalized: str | None = TIME_UNIT_ALIASES.get(unit, unit) if unit else None
        if unit in RATE_UNITS:
            self.diagnostics.append(
                error(
                    "RMV316",
                    f"`{text}` is a rate, but a time is needed here",
                    self.span(token),
                    label="a rate, not a period",
                    help=f"a period of {text} is {decimal(1 / value)}s" if value else None,
                )
            )
            normalized = unit
        elif unit and normalized not in fm.TIME_UNITS:
            # Reported here; the unknown unit is kept so no check calls it "missing".
            self.unknown_unit(token, unit, "a time unit")
            normalized = unit
        return fm.TimeValue(value, normalized, text, self.span(token))
