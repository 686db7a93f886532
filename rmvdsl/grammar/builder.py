"""Builds the AST while lark parses (an inline transformer: no parse tree is made).

Spans come from the tokens each rule received: a node spans from its first to its
last token. Literal problems found here (an unknown unit) become diagnostics.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable, Sequence
from fractions import Fraction
from typing import Any

from lark import Token, Transformer

from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.lang.diagnostics import Diagnostic, Label, error
from rmvdsl.lang.numbers import NumberError, decimal, exact
from rmvdsl.lang.source import Span

_QUANTITY = re.compile(r"^((?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)([A-Za-z]*)$")
RATE_UNITS = {"Hz": Fraction(1), "kHz": Fraction(1000)}
# InfluxDB also writes microseconds as `u`.
TIME_UNIT_ALIASES = {"u": "us"}
_FORMULA_OPERATOR_TOKENS = frozenset(
    {"OR", "AND", "NOT", "IMPLIES", "IFF", "UNTIL", "SINCE", "EVENTUALLY", "ALWAYS", "INT"}
)

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


class AstBuilder(Transformer[Token, Any]):
    """Callbacks named after the grammar's rules and aliases."""

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

    def ident(self, token: Token) -> ast.Ident:
        return ast.Ident(str(token), self.span(token))

    def string(self, token: Token) -> ast.StringLit:
        span = self.span(token)
        value, offsets = unescape(str(token), span.start)
        return ast.StringLit(value, span, offsets)

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
        match = _QUANTITY.match(str(token))
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

    # ---- top level ----

    def start(self, items: list[Any]) -> list[Any]:
        return items

    def system_decl(self, c: list[Any]) -> ast.SystemDecl:
        title = self.string(c[2]) if c[2] is not None else None
        return ast.SystemDecl(self.ident(c[1]), title, span=self.cover(c))

    def import_decl(self, c: list[Any]) -> ast.ImportDecl:
        return ast.ImportDecl(self.string(c[1]), span=self.cover(c))

    def time_unit_decl(self, c: list[Any]) -> ast.TimeUnitDecl:
        return ast.TimeUnitDecl(self.ident(c[1]), span=self.cover(c))

    def ros_decl(self, c: list[Any]) -> ast.RosDecl:
        return ast.RosDecl(self.ident(c[1]), span=self.cover(c))

    def messages_decl(self, c: list[Any]) -> ast.MessagesDecl:
        return ast.MessagesDecl(self.string(c[1]), span=self.cover(c))

    def database_decl(self, c: list[Any]) -> ast.DatabaseDecl:
        members = c[2:]
        return ast.DatabaseDecl(
            self.ident(c[1]) if c[1] is not None else None,
            tuple(m for m in members if isinstance(m, ast.Setting)),
            tuple(m for m in members if isinstance(m, ast.RetentionDecl)),
            tuple(m for m in members if isinstance(m, ast.DownsampleDecl)),
            span=self.cover(c),
        )

    def retention(self, c: list[Any]) -> ast.RetentionDecl:
        return ast.RetentionDecl(self.ident(c[0]), tuple(c[1:]), self.cover(c))

    def downsample(self, c: list[Any]) -> ast.DownsampleDecl:
        return ast.DownsampleDecl(self.ident(c[0]), tuple(c[1:]), self.cover(c))

    def setting(self, c: list[Any]) -> ast.Setting:
        return ast.Setting(self.ident(c[0]), c[1], self.cover(c))

    # ---- values ----

    def string_value(self, c: list[Any]) -> ast.StringLit:
        return self.string(c[0])

    def quantity_value(self, c: list[Any]) -> ast.Value:
        return self.quantity(c[0])

    def negative_value(self, c: list[Any]) -> ast.Value:
        return self.quantity(c[0], negative=True)

    def name_value(self, c: list[Any]) -> ast.NameValue:
        ident = self.ident(c[0])
        return ast.NameValue(ident, ident.span)

    def true_value(self, c: list[Any]) -> ast.BoolLit:
        return ast.BoolLit(True, self.span(c[0]))

    def false_value(self, c: list[Any]) -> ast.BoolLit:
        return ast.BoolLit(False, self.span(c[0]))

    def env_value(self, c: list[Any]) -> ast.EnvRef:
        variable = self.string(c[0])
        return ast.EnvRef(variable, variable.span)

    def list_value(self, c: list[Any]) -> ast.ListValue:
        items = tuple(i for i in c if i is not None)
        return ast.ListValue(items, self.cover(items))

    # ---- topics and variables ----

    def topic_decl(self, c: list[Any]) -> ast.TopicDecl:
        qos = c[4] if c[4] is not None else ()
        return ast.TopicDecl(self.ident(c[1]), c[2], self.string(c[3]), qos, span=self.cover(c))

    def msg_type(self, c: list[Any]) -> ast.MsgType:
        return ast.MsgType(tuple(self.ident(t) for t in c), self.cover(c))

    def qos(self, c: list[Any]) -> tuple[ast.Setting, ...]:
        return tuple(c)

    def var_decl(self, c: list[Any]) -> ast.VarDecl:
        return ast.VarDecl(self.ident(c[1]), c[2], None, span=self.cover(c))

    def var_aggregate_decl(self, c: list[Any]) -> ast.VarDecl:
        return ast.VarDecl(self.ident(c[1]), c[3], self.ident(c[2]), span=self.cover(c))

    def field_ref(self, c: list[Any]) -> ast.FieldRef:
        return ast.FieldRef(self.ident(c[0]), tuple(c[1:]), self.cover(c))

    def plain_segment(self, c: list[Any]) -> ast.Segment:
        return ast.Segment(self.ident(c[0]), None, self.cover(c))

    def index_segment(self, c: list[Any]) -> ast.Segment:
        value, unit, text = self.split_quantity(c[1])
        if unit or value.denominator != 1:
            self.diagnostics.append(
                error(
                    "RMV100",
                    f"array index `{text}` is not a whole number",
                    self.span(c[1]),
                    label="expected an index such as 0, 1, 2, or `*` for every element",
                )
            )
        return ast.Segment(self.ident(c[0]), int(value), self.cover(c))

    def all_segment(self, c: list[Any]) -> ast.Segment:
        return ast.Segment(self.ident(c[0]), "*", self.cover(c))

    # ---- events ----

    def value_event(self, c: list[Any]) -> ast.EventDecl:
        return ast.EventDecl(self.ident(c[1]), False, c[2], tuple(c[3:]), span=self.cover(c))

    def bool_event(self, c: list[Any]) -> ast.EventDecl:
        return ast.EventDecl(self.ident(c[1]), True, c[2], tuple(c[3:]), span=self.cover(c))

    def make_clause(self, kind: str, value: Any) -> ast.Clause:
        return ast.Clause(kind, value, value.span)

    def where_clause(self, c: list[Any]) -> ast.Clause:
        return self.make_clause("where", c[0])

    def group_clause(self, c: list[Any]) -> ast.Clause:
        interval = offset = None
        tags: list[ast.StringLit | ast.Ident] = []
        for item in c:
            if isinstance(item, tuple):
                interval, offset = item
            else:
                tags.append(item)
        group = ast.GroupBy(interval, offset, tuple(tags), self.cover(c))
        return self.make_clause("group", group)

    def group_time(self, c: list[Any]) -> tuple[ast.TimeLit, ast.TimeLit | None]:
        return self.time_lit(c[0]), self.time_lit(c[1]) if c[1] is not None else None

    def group_tag(self, c: list[Any]) -> ast.StringLit | ast.Ident:
        token = c[0]
        return self.string(token) if token.type == "STRING" else self.ident(token)

    def fill_clause(self, c: list[Any]) -> ast.Clause:
        return self.make_clause("fill", c[0])

    def fill_value(self, c: list[Any]) -> ast.Node:
        token = c[0]
        if token.type == "NAME":
            ident = self.ident(token)
            return ast.NameValue(ident, ident.span)
        return self.quantity(token)

    def negative_fill(self, c: list[Any]) -> ast.Node:
        return self.quantity(c[0], negative=True)

    def order_clause(self, c: list[Any]) -> ast.Clause:
        ident = self.ident(c[0])
        return self.make_clause("order", ast.NameValue(ident, ident.span))

    def limit_clause(self, c: list[Any]) -> ast.Clause:
        return self.make_clause("limit", self.quantity(c[0]))

    def resample_clause(self, c: list[Any]) -> ast.Clause:
        every = next((v for k, v in c if k == "every"), None)
        for_ = next((v for k, v in c if k == "for"), None)
        span = self.cover([v for _, v in c])
        return self.make_clause("resample", ast.Resample(every, for_, span))

    def resample_every(self, c: list[Any]) -> tuple[str, ast.TimeLit]:
        return "every", self.time_lit(c[0])

    def resample_for(self, c: list[Any]) -> tuple[str, ast.TimeLit]:
        return "for", self.time_lit(c[0])

    def range_clause(self, c: list[Any]) -> ast.Clause:
        return self.make_clause("range", self.time_lit(c[0]))

    # ---- expressions ----

    def binary(self, op: str, c: list[Any]) -> ast.BinOp:
        return ast.BinOp(op, c[0], c[1], self.cover(c))

    def not_op(self, c: list[Any]) -> ast.UnaryOp:
        return ast.UnaryOp("not", c[-1], self.cover(c))

    def neg(self, c: list[Any]) -> ast.UnaryOp:
        return ast.UnaryOp("-", c[-1], self.cover(c))

    def quantity_expr(self, c: list[Any]) -> ast.Node:
        return self.quantity(c[0])

    def string_expr(self, c: list[Any]) -> ast.StringLit:
        return self.string(c[0])

    def true_expr(self, c: list[Any]) -> ast.BoolLit:
        return ast.BoolLit(True, self.span(c[0]))

    def false_expr(self, c: list[Any]) -> ast.BoolLit:
        return ast.BoolLit(False, self.span(c[0]))

    def name_expr(self, c: list[Any]) -> ast.NameRef:
        ident = self.ident(c[0])
        return ast.NameRef(ident, ident.span)

    def call(self, c: list[Any]) -> ast.Call:
        args = tuple(a for a in c[1:] if a is not None)
        return ast.Call(self.ident(c[0]), args, self.cover(c))

    # ---- alerts and actions ----

    def alert_decl(self, c: list[Any]) -> ast.AlertDecl:
        members = c[2:]
        messages = [m for m in members if isinstance(m, ast.StringLit)]
        for extra in messages[1:]:
            self.duplicate("alert message", extra, messages[0])
        return ast.AlertDecl(
            self.ident(c[1]),
            tuple(m for m in members if isinstance(m, ast.AlertLevel)),
            messages[0] if messages else None,
            tuple(m for m in members if isinstance(m, ast.Setting)),
            tuple(m for m in members if isinstance(m, ast.Action)),
            span=self.cover(c),
        )

    def alert_level(self, c: list[Any]) -> ast.AlertLevel:
        return ast.AlertLevel(c[0], c[1], c[2], self.cover(c))

    def severity(self, c: list[Any]) -> ast.Ident:
        return self.ident(c[0])

    def alert_message(self, c: list[Any]) -> ast.StringLit:
        return self.string(c[0])

    def action(self, c: list[Any]) -> ast.Action:
        args = tuple(a for a in c[1:] if a is not None)
        return ast.Action(self.ident(c[0]), args, self.cover(c))

    def positional_arg(self, c: list[Any]) -> ast.Arg:
        return ast.Arg(None, c[0], self.cover(c))

    def keyword_arg(self, c: list[Any]) -> ast.Arg:
        return ast.Arg(self.ident(c[0]), c[1], self.cover(c))

    # ---- transducers ----

    def transducer_decl(self, c: list[Any]) -> ast.TransducerDecl:
        members = c[2:]
        states: list[ast.Ident] = []
        finals: list[ast.Ident] = []
        initial = None
        complete = False
        transitions = []
        for kind, value in members:
            if kind == "states":
                states.extend(value)
            elif kind == "final":
                finals.extend(value)
            elif kind == "initial":
                if initial is not None:
                    self.duplicate("initial state", value, initial)
                initial = initial or value
            elif kind == "complete":
                complete = True
            else:
                transitions.append(value)
        return ast.TransducerDecl(
            self.ident(c[1]),
            tuple(states),
            initial,
            tuple(finals),
            complete,
            tuple(transitions),
            span=self.cover([c[0], c[1], *(v for _, v in members)]),
        )

    def states(self, c: list[Any]) -> tuple[str, tuple[ast.Ident, ...]]:
        return "states", tuple(self.ident(t) for t in c)

    def finals(self, c: list[Any]) -> tuple[str, tuple[ast.Ident, ...]]:
        return "final", tuple(self.ident(t) for t in c)

    def initial(self, c: list[Any]) -> tuple[str, ast.Ident]:
        return "initial", self.ident(c[0])

    def complete(self, c: list[Any]) -> tuple[str, ast.Ident]:
        return "complete", self.ident(c[0])

    def transition(self, c: list[Any]) -> tuple[str, ast.Transition]:
        output = self.ident(c[3]) if c[3] is not None else None
        transition = ast.Transition(
            self.ident(c[0]), self.ident(c[1]), self.ident(c[2]), output, self.cover(c)
        )
        return "transition", transition

    # ---- properties ----

    def property_decl(self, c: list[Any]) -> ast.PropertyDecl:
        members = [m for m in c[3:] if m is not None]
        return ast.PropertyDecl(
            self.ident(c[1]),
            c[2],
            tuple(m for m in members if isinstance(m, ast.Setting)),
            tuple(m for m in members if isinstance(m, ast.Action)),
            span=self.cover(c),
        )

    def infix_body(self, c: list[Any]) -> ast.InfixFormula:
        return ast.InfixFormula(c[0], c[0].span)

    def latex_body(self, c: list[Any]) -> ast.LatexFormula:
        source = self.string(c[0])
        return ast.LatexFormula(source, None, source.span)

    # ---- whitelists ----

    def whitelist_decl(self, c: list[Any]) -> ast.WhitelistDecl:
        target_token = c[1]
        target: ast.Ident | ast.StringLit = (
            self.string(target_token) if target_token.type == "STRING" else self.ident(target_token)
        )
        lists: dict[str, tuple[ast.StringLit, ...]] = dict(m for m in c[2:] if isinstance(m, tuple))
        return ast.WhitelistDecl(
            target,
            lists.get("publishers"),
            lists.get("subscribers"),
            tuple(m for m in c[2:] if isinstance(m, ast.Action)),
            span=self.cover(c),
        )

    def node_decl(self, c: list[Any]) -> ast.NodeDecl:
        lists: dict[str, tuple[ast.StringLit, ...]] = dict(m for m in c[2:] if isinstance(m, tuple))
        return ast.NodeDecl(
            self.string(c[1]),
            lists.get("publishes"),
            lists.get("subscribes"),
            tuple(m for m in c[2:] if isinstance(m, ast.Action)),
            span=self.cover(c),
        )

    def _pattern_member(self, kind: str, c: list[Any]) -> tuple[str, tuple[ast.StringLit, ...]]:
        return kind, c[0]

    def publishers(self, c: list[Any]) -> tuple[str, tuple[ast.StringLit, ...]]:
        return self._pattern_member("publishers", c)

    def subscribers(self, c: list[Any]) -> tuple[str, tuple[ast.StringLit, ...]]:
        return self._pattern_member("subscribers", c)

    def publishes(self, c: list[Any]) -> tuple[str, tuple[ast.StringLit, ...]]:
        return self._pattern_member("publishes", c)

    def subscribes(self, c: list[Any]) -> tuple[str, tuple[ast.StringLit, ...]]:
        return self._pattern_member("subscribes", c)

    def patterns(self, c: list[Any]) -> tuple[ast.StringLit, ...]:
        return tuple(self.string(t) for t in c)

    def no_patterns(self, c: list[Any]) -> tuple[ast.StringLit, ...]:
        return ()

    def intrusion_decl(self, c: list[Any]) -> ast.IntrusionDecl:
        members = c[1:]
        return ast.IntrusionDecl(
            tuple(m for m in members if isinstance(m, ast.Setting)),
            tuple(m for m in members if isinstance(m, ast.Action)),
            span=self.cover(c),
        )

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


EXPRESSION_OPERATORS = {
    "or_op": "or",
    "and_op": "and",
    "eq": "=",
    "ne": "!=",
    "lt": "<",
    "le": "<=",
    "gt": ">",
    "ge": ">=",
    "match": "=~",
    "nomatch": "!~",
    "bitor": "|",
    "bitxor": "^",
    "bitand": "&",
    "add": "+",
    "sub": "-",
    "mul": "*",
    "div": "/",
    "mod": "%",
}


def _binary_callback(op: str) -> Callable[[AstBuilder, list[Any]], ast.BinOp]:
    def build(self: AstBuilder, c: list[Any]) -> ast.BinOp:
        return self.binary(op, c)

    return build


for _rule, _op in EXPRESSION_OPERATORS.items():
    setattr(AstBuilder, _rule, _binary_callback(_op))
