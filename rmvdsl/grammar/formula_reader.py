"""A formula (or term) given on its own, read without lark where it can be.

`rmv eval` and `rmv sat` read one formula from the command line. lark's import and
its tables were a third of `rmv eval`'s start (167 M of 494 M instructions in a
fresh install). This reader takes the infix grammar's `formula`
and `term` rules (formula.lark, lexical.lark) by recursive descent and builds the
same nodes, with the same spans, as lark's parser with `FormulaRules` does.

It reads well-formed formulas only. On anything else it declines (None): a syntax
error, a unit it would have to report, a number out of range, a word lark's
contextual lexer might read otherwise (`and`, `until`, ... where an operand
stands), a nesting deeper than the stack. lark's parser then reads the text, and
explains it where it is wrong, as before. So this reader never words an error,
and what it reads it reads as lark does: tests/test_formula_reader.py compares
both, spans included, on random formulas and on random strings of their tokens.
"""

from __future__ import annotations

import re
from fractions import Fraction
from typing import NamedTuple

from rmvdsl.grammar import formula as fm
from rmvdsl.grammar.quantities import QUANTITY, RATE_UNITS, TIME_UNIT_ALIASES
from rmvdsl.lang.numbers import NumberError, exact
from rmvdsl.lang.source import Span

# lexical.lark's terminals (WS and COMMENT skipped), and the symbols of formula.lark
_TOKENS = re.compile(
    r"""(?P<skip>[ \t\f\r\n]+|//[^\n]*)
      | (?P<word>[A-Za-z_][A-Za-z0-9_]*)
      | (?P<quantity>(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?(?:[A-Za-z]+)?)
      | (?P<symbol><->|->|<=|>=|==|!=|[<>=()\[\]+\-*])""",
    re.VERBOSE,
)
_UNARY_TEMPORAL = frozenset({"eventually", "always", "once", "historically"})
_BINARY_TEMPORAL = frozenset({"until", "since"})
_PREFIXES = _UNARY_TEMPORAL | {"not"}
_OR, _AND, _DURATION = frozenset({"or"}), frozenset({"and"}), frozenset({"duration"})
_CONSTANTS = {"true": True, "false": False}
# Words lark's contextual lexer reads as a name where an operand stands (they are
# not among that state's terminals): declined, lark says what it makes of them.
_OPERATOR_WORDS = frozenset({"and", "or", *_BINARY_TEMPORAL})
_COMPARISONS = frozenset({"<", "<=", ">", ">=", "==", "!="})
_BOUNDS = frozenset({"<", "<=", "="})


class _Token(NamedTuple):
    kind: str  # "word", "quantity", or the symbol itself
    text: str
    start: int
    end: int


class _Decline(Exception):
    """Not a text this reader takes: lark's parser reads it."""


def read_formula(text: str, path: str, kind: str = "formula") -> fm.Formula | fm.Term | None:
    """The formula (kind "formula") or term (kind "term") written in `text`, with
    spans in `path`; None where lark's parser must read it."""
    try:
        reader = _Reader(_tokens(text), path)
        node = reader.formula() if kind == "formula" else reader.term()
        if reader.next() is not None:
            raise _Decline
        return node
    except (_Decline, RecursionError):
        return None


def _tokens(text: str) -> list[_Token]:
    tokens, position = [], 0
    while position < len(text):
        match = _TOKENS.match(text, position)
        if match is None:
            raise _Decline
        group, position = match.lastgroup, match.end()
        if group == "skip":
            continue
        found = match.group()
        tokens.append(
            _Token(found if group == "symbol" else str(group), found, match.start(), position)
        )
    return tokens


class _Reader:
    """formula.lark's rules, loosest first; each method reads one rule."""

    def __init__(self, tokens: list[_Token], path: str) -> None:
        self.tokens, self.index, self.path = tokens, 0, path

    def next(self) -> _Token | None:
        return self.tokens[self.index] if self.index < len(self.tokens) else None

    def take(self, *kinds: str) -> _Token:
        token = self.next()
        if token is None or token.kind not in kinds:
            raise _Decline
        self.index += 1
        return token

    def taking(self, *symbols: str) -> _Token | None:
        """The next token if it is one of these symbols (taken), else None."""
        token = self.next()
        if token is not None and token.kind in symbols:
            self.index += 1
            return token
        return None

    def taking_word(self, words: frozenset[str]) -> _Token | None:
        """The next token if it is one of these words (taken), else None."""
        token = self.next()
        if token is not None and token.kind == "word" and token.text in words:
            self.index += 1
            return token
        return None

    # ---- formulas ----

    def formula(self) -> fm.Formula:
        """`f_or -> formula` (to the right) or `f_or <-> f_or`: a chain of `->`
        whose last operand may be an `<->`, read in a loop (a long chain does not
        recurse)."""
        operands = [self.f_or()]
        while self.taking("->"):
            operands.append(self.f_or())
        if self.taking("<->"):
            operands.append(self.binary("<->", operands.pop(), self.f_or()))
        node = operands.pop()
        while operands:
            node = self.binary("->", operands.pop(), node)
        return node

    def f_or(self) -> fm.Formula:
        node = self.f_and()
        while self.taking_word(_OR):
            node = self.binary("or", node, self.f_and())
        return node

    def f_and(self) -> fm.Formula:
        node = self.f_binary()
        while self.taking_word(_AND):
            node = self.binary("and", node, self.f_binary())
        return node

    def f_binary(self) -> fm.Formula:
        left = self.f_unary()
        operator = self.taking_word(_BINARY_TEMPORAL)
        if operator is None:
            return left
        bound = self.bound()
        right = self.f_unary()
        return fm.Temporal(operator.text, bound, left, right, self.cover(left.span, right.span))

    def f_unary(self) -> fm.Formula:
        keyword = self.taking_word(_PREFIXES)
        if keyword is None:
            return self.f_atom()
        bound = self.bound() if keyword.text != "not" else None
        body = self.f_unary()
        span = self.cover(self.span(keyword), body.span)
        if keyword.text == "not":
            return fm.Not(body, span)
        return fm.Temporal(keyword.text, bound, None, body, span)

    def f_atom(self) -> fm.Formula:
        token = self.next()
        if token is None:
            raise _Decline
        if token.kind == "(":
            self.index += 1
            inner = self.formula()
            self.take(")")
            return inner
        if token.kind == "word" and token.text != "duration":
            if token.text in _OPERATOR_WORDS:
                raise _Decline
            self.index += 1
            if token.text in _CONSTANTS:
                return fm.Const(_CONSTANTS[token.text], self.span(token))
            return fm.Prop(token.text, self.span(token))
        left = self.term()
        operator = self.take(*_COMPARISONS)
        right = self.term()
        return fm.Compare(operator.text, left, right, self.cover(left.span, right.span))

    def bound(self) -> fm.Bound | None:
        if not self.taking("["):
            return None
        operator = self.take(*_BOUNDS)
        quantity = self.take("quantity")
        self.take("]")
        return fm.Bound(operator.text, self.time_value(quantity), self.span(quantity))

    # ---- terms ----

    def term(self) -> fm.Term:
        node = self.t_product()
        while operator := self.taking("+", "-"):
            right = self.t_product()
            node = fm.Arith(operator.text, node, right, self.cover(node.span, right.span))
        return node

    def t_product(self) -> fm.Term:
        node = self.t_atom()
        while self.taking("*"):
            right = self.t_atom()
            node = fm.Arith("*", node, right, self.cover(node.span, right.span))
        return node

    def t_atom(self) -> fm.Term:
        keyword = self.taking_word(_DURATION)
        if keyword is not None:
            self.take("[")
            window = self.time_value(self.take("quantity"))
            self.take("]")
            self.take("(")
            body = self.formula()
            closing = self.take(")")
            return fm.Duration(window, body, self.cover(self.span(keyword), self.span(closing)))
        negative = self.taking("-") is not None
        quantity = self.take("quantity")
        value, unit = self.number(quantity)
        time = self.time_value(quantity) if unit else None
        return fm.Number(-value if negative else value, time, self.span(quantity))

    # ---- literals and spans, as FormulaRules makes them ----

    def number(self, token: _Token) -> tuple[Fraction, str]:
        match = QUANTITY.match(token.text)
        if match is None:
            raise _Decline
        try:
            return exact(match.group(1)), match.group(2)
        except NumberError:
            raise _Decline from None

    def time_value(self, token: _Token) -> fm.TimeValue:
        value, unit = self.number(token)
        normalized = TIME_UNIT_ALIASES.get(unit, unit) if unit else None
        if unit in RATE_UNITS or (normalized is not None and normalized not in fm.TIME_UNITS):
            raise _Decline  # a rate, or a unit to report
        return fm.TimeValue(value, normalized, token.text, self.span(token))

    def binary(self, operator: str, left: fm.Formula, right: fm.Formula) -> fm.Binary:
        return fm.Binary(operator, left, right, self.cover(left.span, right.span))

    def span(self, token: _Token) -> Span:
        return Span(self.path, token.start, token.end)

    @staticmethod
    def cover(first: Span, last: Span) -> Span:
        """FormulaRules' cover of its items: from the first's start to the later end."""
        return Span(first.path, first.start, max(first.end, last.end))
