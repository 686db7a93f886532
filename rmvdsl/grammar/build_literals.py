"""The literals of declarations and expressions as syntax nodes: identifiers,
strings, numbers with their units (the formulas' own literals are in BuilderBase)."""

from __future__ import annotations

from lark import Token

from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.grammar.build_base import unescape
from rmvdsl.grammar.build_formulas import FormulaRules
from rmvdsl.grammar.quantities import RATE_UNITS, TIME_UNIT_ALIASES


class LiteralRules(FormulaRules):
    """Literal tokens as the nodes declarations and expressions hold."""

    def ident(self, token: Token) -> ast.Ident:
        return ast.Ident(str(token), self.span(token))

    def string(self, token: Token) -> ast.StringLit:
        span = self.span(token)
        value, offsets = unescape(str(token), span.start)
        return ast.StringLit(value, span, offsets)

    def quantity(self, token: Token, negative: bool = False) -> ast.Value:
        value, unit, text = self.split_quantity(token)
        value = -value if negative else value
        text = "-" + text if negative else text
        span = self.span(token)
        if not unit:
            return ast.NumberLit(value, text, span)
        if unit in RATE_UNITS:
            return ast.RateLit(value * RATE_UNITS[unit], text, span)
        normalized = TIME_UNIT_ALIASES.get(unit, unit)
        if normalized in fm.TIME_UNITS:
            return ast.TimeLit(fm.TimeValue(value, normalized, text, span), span)
        self.unknown_unit(token, unit, "a time unit or Hz")
        return ast.NumberLit(value, text, span)

    def time_lit(self, token: Token) -> ast.TimeLit:
        time = self.time_value(token)
        return ast.TimeLit(time, time.span)
