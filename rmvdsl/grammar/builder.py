"""Builds the AST while lark parses (an inline transformer: no parse tree is made).

Spans come from the tokens each rule received: a node spans from its first to its
last token. Literal problems found here (an unknown unit) become diagnostics.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rmvdsl.grammar import ast
from rmvdsl.grammar.build_literals import LiteralRules
from rmvdsl.lang.diagnostics import error


class AstBuilder(LiteralRules):
    """Callbacks named after the grammar's rules and aliases: the declarations and
    expressions here, their literals in LiteralRules, the formulas in FormulaRules,
    spans in BuilderBase."""

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
