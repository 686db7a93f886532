"""Parsing a declaration chunk that has no error: the first try of every chunk.

lark's contextual lexer spent about a third of a large spec's parse in its own
bookkeeping around each regular-expression match (a generator per token, a line
counter object, a scanner object per state). This loop does the same work with
lark's own compiled patterns, per parser state: the same tokens (type, text,
positions, lines, columns), the same keyword callbacks. It drives lark's LALR table
itself too, compiled once into one row per state (a shift is the next state, a
reduction its length, tree callback and rule name): lark's `feed_token` looks each
reduction's callback up by its rule, whose hash and equality are Python methods
(parsing a 15,904-line spec took 12.2 G instructions with it, 10.7 G without).
Anything it cannot do alike (a character no pattern of the state matches, a token
the table refuses) raises NotUnbroken, and the chunk is parsed again by
rmvdsl.grammar.recovery, with lark's own parser, which reports the error; a lark
whose insides are not as expected makes every chunk go that way.
tests/test_parser.py compares both on every chunk of the examples and on
random edits of them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from lark import Token
from lark.parsers.lalr_analysis import Shift

from rmvdsl.grammar.grammars import spec_parser


class NotUnbroken(Exception):
    """The chunk has an error (or the lexer's insides are not lark's as known)."""


# Per parser state: lark's compiled patterns of the terminals it accepts, the
# ignored and newline-bearing terminals, and the terminals' callbacks.
_Plan = tuple[tuple[Any, ...], frozenset[str], frozenset[str], dict[str, Any]]
# Per parser state, by terminal or rule name: a shift (or a goto) is the next
# state; a reduction is how many values it takes, its tree callback, its rule name.
_Row = dict[str, Any]


@dataclass(frozen=True)
class _Compiled:
    parser: Any
    plans: dict[int, _Plan]
    rows: list[_Row]
    start_state: int
    end_state: int


_COMPILED: list[_Compiled] = []  # the parser's, with the parser


def parse_unbroken(text: str, start: int, end: int, line: int) -> tuple[Any, Token | None]:
    """The parse of text[start:end] (beginning a line, at `line`) and its last
    token; NotUnbroken where the chunk has an error."""
    compiled = _compiled()
    plans, rows = compiled.plans, compiled.rows
    stack: list[int] = [compiled.start_state]
    values: list[Any] = []
    push, push_value = stack.append, values.append
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
        kind = token.type  # a keyword's callback names its terminal
        while True:  # reduce as the table says, then shift the token
            action = rows[stack[-1]].get(kind)
            if action is None:
                raise NotUnbroken
            if action.__class__ is int:
                push(action)
                push_value(token)
                break
            size, build, rule = action
            children = values[-size:] if size else []
            if size:
                del stack[-size:], values[-size:]
            push_value(build(children))
            push(rows[stack[-1]][rule])
        last = token
    return _finish(compiled, stack, values), last


def _finish(compiled: _Compiled, stack: list[int], values: list[Any]) -> Any:
    """The chunk's tree: the reductions the end of the input calls for."""
    rows = compiled.rows
    while True:
        action = rows[stack[-1]].get("$END")
        if action is None or action.__class__ is int:
            raise NotUnbroken
        size, build, rule = action
        children = values[-size:] if size else []
        if size:
            del stack[-size:], values[-size:]
        values.append(build(children))
        stack.append(rows[stack[-1]][rule])
        if stack[-1] == compiled.end_state:
            return values[-1]


def _compiled() -> _Compiled:
    parser, _ = spec_parser()
    if _COMPILED and _COMPILED[0].parser is parser:
        return _COMPILED[0]
    interactive = parser.parse_interactive("", start="start")
    try:
        conf = interactive.parser_state.parse_conf
        compiled = _Compiled(
            parser,
            _built(interactive.lexer_thread.lexer),
            _rows(conf.states, conf.callbacks),
            conf.start_state,
            conf.end_state,
        )
    except (AttributeError, TypeError, KeyError) as exc:  # another lark: recover every chunk
        raise NotUnbroken from exc
    _COMPILED[:] = [compiled]
    return compiled


def _rows(states: dict[int, dict[str, Any]], callbacks: dict[Any, Any]) -> list[_Row]:
    """lark's LALR table as one row per state (states are numbered from 0)."""
    if sorted(states) != list(range(len(states))):
        raise TypeError("parser states not numbered from 0")
    if any(isinstance(key, str) for key in callbacks):  # lark would call it on a shift
        raise TypeError("a terminal with a tree callback")
    rows: list[_Row] = []
    for state in range(len(states)):
        row: _Row = {}
        for name, (action, argument) in states[state].items():
            if action is Shift:
                row[name] = int(argument)
            else:
                row[name] = (len(argument.expansion), callbacks[argument], argument.origin.name)
        rows.append(row)
    return rows


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
