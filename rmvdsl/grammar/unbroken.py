"""Parsing a declaration chunk that has no error: the first try of every chunk.

lark's contextual lexer spent about a third of a large spec's parse in its own
bookkeeping around each regular-expression match (a generator per token, a line
counter object, a scanner object per state). This loop does the same work with
lark's own compiled patterns, per parser state, and feeds lark's LALR parser
directly: the same tokens (type, text, positions, lines, columns), the same
keyword callbacks, the same parser. Anything it cannot do alike (a character no
pattern of the state matches, a token the parser refuses) raises NotUnbroken,
and the chunk is parsed again by rmvdsl.grammar.recovery, which reports the error;
a lark whose insides are not as expected makes every chunk go that way.
tests/test_parser.py compares both on every chunk of the examples and on
random edits of them.
"""

from __future__ import annotations

from typing import Any

from lark import Token

from rmvdsl.grammar.grammars import spec_parser


class NotUnbroken(Exception):
    """The chunk has an error (or the lexer's insides are not lark's as known)."""


# Per parser state: lark's compiled patterns of the terminals it accepts, the
# ignored and newline-bearing terminals, and the terminals' callbacks.
_Plan = tuple[tuple[Any, ...], frozenset[str], frozenset[str], dict[str, Any]]
_PLANS: list[tuple[Any, dict[int, _Plan]]] = []  # the parser's, with the parser


def parse_unbroken(text: str, start: int, end: int, line: int) -> tuple[Any, Token | None]:
    """The parse of text[start:end] (beginning a line, at `line`) and its last
    token; NotUnbroken where the chunk has an error."""
    parser, _ = spec_parser()
    interactive = parser.parse_interactive("", start="start")
    plans = _plans(parser, interactive)
    state = interactive.parser_state
    feed, stack = state.feed_token, state.state_stack
    make = Token._future_new  # lark's constructor, without its deprecation check
    position, line_start, last = start, start, None
    while position < end:
        patterns, ignored, newlines, callbacks = plans[stack[-1]]
        for pattern in patterns:
            found = pattern.match(text, position, end)
            if found is not None:
                break
        else:
            raise NotUnbroken
        kind, value = found.lastgroup, found.group(0)
        stop = position + len(value)
        first_line, column = line, position - line_start + 1
        if kind in newlines:
            count = value.count("\n")
            if count:
                line += count
                line_start = position + value.rindex("\n") + 1
        if kind in ignored and kind not in callbacks:
            position = stop
            continue
        token = make(kind, value, position, first_line, column, line, stop - line_start + 1, stop)
        position = stop
        callback = callbacks.get(kind)
        if callback is not None:
            token = callback(token)
        if kind in ignored:
            continue
        feed(token)
        last = token
    end_token = Token.new_borrow_pos("$END", "", last) if last else Token("$END", "", 0, 1, 1)
    return feed(end_token, True), last


def _plans(parser: Any, interactive: Any) -> dict[int, _Plan]:
    if _PLANS and _PLANS[0][0] is parser:
        return _PLANS[0][1]
    try:
        plans = _built(interactive.lexer_thread.lexer)
    except (AttributeError, TypeError) as exc:  # another lark: recover every chunk
        raise NotUnbroken from exc
    _PLANS[:] = [(parser, plans)]
    return plans


def _built(lexer: Any) -> dict[int, _Plan]:
    """The plan of every parser state, from lark's contextual lexer (one basic
    lexer per set of acceptable terminals, shared by states)."""
    by_lexer: dict[int, _Plan] = {}
    plans = {}
    for state, basic in lexer.lexers.items():
        plan = by_lexer.get(id(basic))
        if plan is None:
            scanner = basic.scanner  # built on first use
            plan = by_lexer[id(basic)] = (
                tuple(scanner._mres),
                frozenset(basic.ignore_types),
                frozenset(basic.newline_types),
                dict(basic.callback),
            )
        plans[state] = plan
    return plans
