"""The AST builder's callbacks for RMTLD3 formulas (the infix and the LaTeX grammar
share them), their terms, and LaTeX duration windows written as arithmetic."""

from __future__ import annotations

from typing import Any

from lark import Token

from rmvdsl.grammar import formula as fm
from rmvdsl.grammar.build_base import BuilderBase
from rmvdsl.lang.numbers import decimal

_FORMULA_OPERATOR_TOKENS = frozenset(
    {"OR", "AND", "NOT", "IMPLIES", "IFF", "UNTIL", "SINCE", "EVENTUALLY", "ALWAYS", "INT"}
)


class FormulaRules(BuilderBase):
    """Callbacks of the formula rules (`f_*`, `t_*`, `w_*`, bounds)."""

    # ---- RMTLD3 formulas (infix and LaTeX share these callbacks) ----

    @staticmethod
    def operands(c: list[Any]) -> list[Any]:
        return [
            x
            for x in c
            if x is not None and not (isinstance(x, Token) and x.type in _FORMULA_OPERATOR_TOKENS)
        ]

    def f_binary_op(self, op: str, c: list[Any]) -> fm.Binary:
        left, right = self.operands(c)
        return fm.Binary(op, left, right, self.cover(c))

    def f_implies(self, c: list[Any]) -> fm.Binary:
        return self.f_binary_op("->", c)

    def f_iff(self, c: list[Any]) -> fm.Binary:
        return self.f_binary_op("<->", c)

    def f_or(self, c: list[Any]) -> fm.Binary:
        return self.f_binary_op("or", c)

    def f_and(self, c: list[Any]) -> fm.Binary:
        return self.f_binary_op("and", c)

    def _temporal_binary(self, op: str, c: list[Any]) -> fm.Temporal:
        left, bound, right = (x for x in c if not _is_operator(x))
        return fm.Temporal(op, bound, left, right, self.cover(c))

    def f_until(self, c: list[Any]) -> fm.Temporal:
        return self._temporal_binary("until", c)

    def f_since(self, c: list[Any]) -> fm.Temporal:
        return self._temporal_binary("since", c)

    def _temporal_unary(self, op: str, c: list[Any]) -> fm.Temporal:
        bound, body = (x for x in c if not isinstance(x, Token))
        return fm.Temporal(op, bound, None, body, self.cover(c))

    def f_eventually(self, c: list[Any]) -> fm.Temporal:
        return self._temporal_unary("eventually", c)

    def f_always(self, c: list[Any]) -> fm.Temporal:
        return self._temporal_unary("always", c)

    def f_once(self, c: list[Any]) -> fm.Temporal:
        return self._temporal_unary("once", c)

    def f_historically(self, c: list[Any]) -> fm.Temporal:
        return self._temporal_unary("historically", c)

    def f_not(self, c: list[Any]) -> fm.Not:
        return fm.Not(c[-1], self.cover(c))

    def f_prop(self, c: list[Any]) -> fm.Prop:
        return fm.Prop(str(c[0]), self.span(c[0]))

    def f_true(self, c: list[Any]) -> fm.Const:
        return fm.Const(True, self.span(c[0]))

    def f_false(self, c: list[Any]) -> fm.Const:
        return fm.Const(False, self.span(c[0]))

    def _compare(self, op: str, c: list[Any]) -> fm.Compare:
        left, right = (x for x in c if not isinstance(x, Token))
        return fm.Compare(op, left, right, self.cover(c))

    def f_lt(self, c: list[Any]) -> fm.Compare:
        return self._compare("<", c)

    def f_le(self, c: list[Any]) -> fm.Compare:
        return self._compare("<=", c)

    def f_gt(self, c: list[Any]) -> fm.Compare:
        return self._compare(">", c)

    def f_ge(self, c: list[Any]) -> fm.Compare:
        return self._compare(">=", c)

    def f_eq(self, c: list[Any]) -> fm.Compare:
        return self._compare("==", c)

    def f_ne(self, c: list[Any]) -> fm.Compare:
        return self._compare("!=", c)

    def _bound(self, op: str, c: list[Any]) -> fm.Bound:
        token = c[-1]
        return fm.Bound(op, self.time_value(token), self.cover(c))

    def bound_lt(self, c: list[Any]) -> fm.Bound:
        return self._bound("<", c)

    def bound_le(self, c: list[Any]) -> fm.Bound:
        return self._bound("<=", c)

    def bound_eq(self, c: list[Any]) -> fm.Bound:
        return self._bound("=", c)

    def _arith(self, op: str, c: list[Any]) -> fm.Arith:
        left, right = (x for x in c if not isinstance(x, Token))
        return fm.Arith(op, left, right, self.cover(c))

    def t_add(self, c: list[Any]) -> fm.Arith:
        return self._arith("+", c)

    def t_sub(self, c: list[Any]) -> fm.Arith:
        return self._arith("-", c)

    def t_mul(self, c: list[Any]) -> fm.Arith:
        return self._arith("*", c)

    def _number_term(self, token: Token, negative: bool) -> fm.Number:
        value, unit, _ = self.split_quantity(token)
        time = self.time_value(token) if unit else None
        value = -value if negative else value
        return fm.Number(value, time, self.span(token))

    def t_number(self, c: list[Any]) -> fm.Number:
        return self._number_term(c[-1], negative=False)

    def t_negative(self, c: list[Any]) -> fm.Number:
        return self._number_term(c[-1], negative=True)

    def t_duration(self, c: list[Any]) -> fm.Duration:
        window = next(
            x
            for x in c
            if isinstance(x, fm.TimeValue)
            or (isinstance(x, Token) and x.type in {"QUANTITY", "NUMBER"})
        )
        if isinstance(window, Token):
            window = self.time_value(window)
        body = next(x for x in c if isinstance(x, fm.Formula))
        return fm.Duration(window, body, self.cover(c))

    # ---- LaTeX duration windows written as constant arithmetic ----

    def w_number(self, c: list[Any]) -> fm.TimeValue:
        return self.time_value(c[0])

    def _window(self, op: str, c: list[Any]) -> fm.TimeValue:
        left, right = c[0], c[-1]
        value = {
            "+": left.value + right.value,
            "-": left.value - right.value,
            "*": left.value * right.value,
        }[op]
        span = left.span.cover(right.span)
        return fm.TimeValue(value, None, decimal(value), span)

    def w_add(self, c: list[Any]) -> fm.TimeValue:
        return self._window("+", c)

    def w_sub(self, c: list[Any]) -> fm.TimeValue:
        return self._window("-", c)

    def w_mul(self, c: list[Any]) -> fm.TimeValue:
        return self._window("*", c)


def _is_operator(item: Any) -> bool:
    return isinstance(item, Token) and item.type in _FORMULA_OPERATOR_TOKENS
