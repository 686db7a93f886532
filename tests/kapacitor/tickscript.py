"""A TICKscript checker for the tests, written from Kapacitor's own documentation
(tick/TICKscript.md's grammar) and its lexer's rules (tick/ast/lex.go: strings,
references, numbers and durations), with the part of the pipeline reference the
kapacitor target uses: which node may follow which, each node's properties and the
kinds of their arguments, and the functions a lambda may call. Kapacitor itself is
not installable here; its parser and pipeline validation will judge the scripts in
the end, and this checker refuses what they refuse for the constructs we write.

`parse(text)` returns the statements; `check(text)` raises TickError on anything
wrong, naming line and column.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, ClassVar


class TickError(ValueError):
    pass


@dataclass
class Token:
    kind: str  # ident, number, duration, string, reference, regex, op, punct, keyword
    text: str
    line: int
    column: int
    value: Any = None


_OPERATORS = ("==", "!=", "<=", ">=", "=~", "!~", "+", "-", "*", "/", "<", ">", "!")
_DURATION_UNITS = ("ms", "u", "µ", "s", "m", "h", "d", "w")


def _position(text: str, index: int) -> tuple[int, int]:
    line = text.count("\n", 0, index) + 1
    return line, index - (text.rfind("\n", 0, index) + 1) + 1


def _delimited(text: str, start: int, quote: str, what: str) -> tuple[str, int]:
    """The text between `quote`s from `start`, where only a backslash before the
    quote escapes (lex.go's rule; newString and newReference unescape only that)."""
    index = start + 1
    while index < len(text):
        char = text[index]
        if char == "\\" and text.startswith(quote, index + 1):
            index += 2
            continue
        if char == quote:
            return text[start + 1 : index].replace("\\" + quote, quote), index + 1
        index += 1
    raise TickError(f"unterminated {what}")


def _string(text: str, start: int) -> tuple[str, int]:
    """A string literal at `start`: single quotes, or triple quotes with no escapes
    (lex.go ends those at the first three quotes in a row)."""
    if text.startswith("'''", start):
        end = text.find("'''", start + 3)
        if end < 0:
            raise TickError("unterminated string")
        return text[start + 3 : end], end + 3
    return _delimited(text, start, "'", "string")


def _reference(text: str, start: int) -> tuple[str, int]:
    return _delimited(text, start, '"', "field reference")


def tokens(text: str) -> list[Token]:
    out: list[Token] = []
    index = 0
    while index < len(text):
        char = text[index]
        line, column = _position(text, index)
        if char in " \t\r\n":
            index += 1
        elif text.startswith("//", index):
            end = text.find("\n", index)
            index = len(text) if end < 0 else end
        elif char in "'\"":
            kind, scan = ("string", _string) if char == "'" else ("reference", _reference)
            try:
                value, end = scan(text, index)
            except TickError as error:
                raise TickError(f"{line}:{column}: {error}") from None
            out.append(Token(kind, text[index:end], line, column, value))
            index = end
        elif char.isdigit() or (
            char == "." and index + 1 < len(text) and text[index + 1].isdigit()
        ):
            match = re.compile(r"\d*(\.\d*)?").match(text, index)
            assert match is not None
            end = match.end()
            unit = next((u for u in _DURATION_UNITS if text.startswith(u, end)), None)
            if unit is not None and match.group(1) is None:
                out.append(Token("duration", text[index : end + len(unit)], line, column))
                index = end + len(unit)
            else:
                if text[index:end].count(".") > 1:
                    raise TickError(f"{line}:{column}: multiple decimals in number")
                out.append(Token("number", text[index:end], line, column))
                index = end
        elif text.startswith("lambda:", index):
            out.append(Token("keyword", "lambda:", line, column))
            index += len("lambda:")
        elif char.isalpha() or char == "_":
            match = re.compile(r"[A-Za-z_][A-Za-z0-9_]*").match(text, index)
            assert match is not None
            word = match.group(0)
            kind = "keyword" if word in ("var", "dbrp", "TRUE", "FALSE", "AND", "OR") else "ident"
            out.append(Token(kind, word, line, column))
            index = match.end()
        elif char in "|.@(),[]=":
            if char == "=" and text.startswith("==", index):
                out.append(Token("op", "==", line, column))
                index += 2
            elif char == "=" and text.startswith("=~", index):
                out.append(Token("op", "=~", line, column))
                index += 2
            else:
                out.append(Token("punct", char, line, column))
                index += 1
        else:
            op = next((o for o in _OPERATORS if text.startswith(o, index)), None)
            if op is None:
                raise TickError(f"{line}:{column}: unexpected {char!r}")
            out.append(Token("op", op, line, column))
            index += len(op)
    return out


# ---- the parser (tick/TICKscript.md) ----


@dataclass
class Call:
    name: str
    args: list[Any]
    line: int
    column: int


@dataclass
class Chain:
    """`|node(...)` or `.property(...)` or `@udf(...)` steps after a head."""

    head: str
    steps: list[tuple[str, Call]] = field(default_factory=list)


@dataclass
class Lambda:
    expr: Any


@dataclass
class Expr:
    kind: str  # number, duration, string, bool, reference, regex, star, call, unary, binary, ident
    value: Any


class Parser:
    def __init__(self, text: str) -> None:
        self.tokens = tokens(text)
        self.index = 0

    def peek(self, offset: int = 0) -> Token | None:
        at = self.index + offset
        return self.tokens[at] if at < len(self.tokens) else None

    def take(self, kind: str | None = None, text: str | None = None) -> Token:
        token = self.peek()
        if token is None:
            raise TickError(f"unexpected end of script, expected {text or kind}")
        if (kind and token.kind != kind) or (text and token.text != text):
            raise TickError(
                f"{token.line}:{token.column}: unexpected {token.text!r}, expected {text or kind}"
            )
        self.index += 1
        return token

    def at(self, kind: str, text: str | None = None) -> bool:
        token = self.peek()
        return token is not None and token.kind == kind and (text is None or token.text == text)

    def program(self) -> list[Any]:
        statements: list[Any] = []
        while self.peek() is not None:
            statements.append(self.statement())
        if not statements:
            raise TickError("an empty script")
        return statements

    def statement(self) -> Any:
        if self.at("keyword", "dbrp"):
            self.take()
            database = self.take("reference").value
            self.take("punct", ".")
            policy = self.take("reference").value
            return ("dbrp", database, policy)
        if self.at("keyword", "var"):
            self.take()
            name = self.take("ident").text
            if self.at("punct", "="):
                self.take()
                return ("var", name, self.expression())
            return ("typedecl", name, self.take("ident").text)
        return ("expr", self.expression())

    def expression(self) -> Any:
        if self.at("ident") and not (self.peek(1) and self.peek(1).text == "("):  # type: ignore[union-attr]
            head = self.take().text
            return self.chain(Chain(head))
        if self.at("ident"):
            call = self.function()
            return self.chain(Chain(call.name, [("head", call)]))
        if self.at("punct", "["):
            return self.string_list()
        return self.primary_expr()

    def chain(self, chain: Chain) -> Chain:
        while self.at("punct", "|") or self.at("punct", ".") or self.at("punct", "@"):
            sign = self.take().text
            chain.steps.append((sign, self.function()))
        return chain

    def function(self) -> Call:
        name = self.take("ident")
        self.take("punct", "(")
        args: list[Any] = []
        while not self.at("punct", ")"):
            args.append(self.parameter())
            if not self.at("punct", ")"):
                self.take("punct", ",")
        self.take("punct", ")")
        return Call(name.text, args, name.line, name.column)

    def parameter(self) -> Any:
        if self.at("keyword", "lambda:"):
            self.take()
            return Lambda(self.primary_expr())
        if self.at("punct", "["):
            return self.string_list()
        if self.at("ident") and not (self.peek(1) and self.peek(1).text == "("):  # type: ignore[union-attr]
            return Expr("ident", self.take().text)
        return self.primary_expr()

    def string_list(self) -> Expr:
        self.take("punct", "[")
        items = []
        while not self.at("punct", "]"):
            token = self.take()
            if token.kind not in ("string", "ident") and token.text != "*":
                raise TickError(f"{token.line}:{token.column}: not a string list item")
            items.append(token.value if token.kind == "string" else token.text)
            if not self.at("punct", "]"):
                self.take("punct", ",")
        self.take("punct", "]")
        return Expr("list", items)

    _PRECEDENCE: ClassVar[dict[str, int]] = {
        "OR": 1, "AND": 2, "==": 3, "!=": 3, "<": 3, "<=": 3, ">": 3, ">=": 3, "=~": 3,
        "!~": 3, "+": 4, "-": 4, "*": 5, "/": 5,
    }  # fmt: skip

    def primary_expr(self, minimum: int = 1) -> Expr:
        left = self.primary()
        while True:
            token = self.peek()
            if token is None or token.text not in self._PRECEDENCE or token.kind == "string":
                return left
            precedence = self._PRECEDENCE[token.text]
            if precedence < minimum:
                return left
            self.take()
            right = self.primary_expr(precedence + 1)
            left = Expr("binary", (token.text, left, right))

    def primary(self) -> Expr:
        token = self.take()
        if token.text == "(" and token.kind == "punct":
            inner = self.primary_expr()
            self.take("punct", ")")
            return inner
        if token.kind == "op" and token.text in ("-", "!"):
            return Expr("unary", (token.text, self.primary()))
        if token.kind == "op" and token.text == "*":
            return Expr("star", "*")
        if token.kind in ("number", "duration", "string", "reference"):
            return Expr(token.kind, token.value if token.kind in ("string", "reference")
                        else token.text)  # fmt: skip
        if token.kind == "keyword" and token.text in ("TRUE", "FALSE"):
            return Expr("bool", token.text == "TRUE")
        if token.kind == "ident":
            if self.at("punct", "("):
                self.index -= 1
                call = self.function()
                return Expr("call", call)
            return Expr("ident", token.text)
        raise TickError(f"{token.line}:{token.column}: unexpected {token.text!r} in an expression")


def parse(text: str) -> list[Any]:
    return Parser(text).program()


# ---- the pipeline (Kapacitor's node reference, the parts the target writes) ----

STRING, LAMBDA, DURATION, INT, FLOAT = "string", "lambda", "duration", "int", "float"

# property -> (kinds of the required arguments, the kind of any further ones)
NODES: dict[str, dict[str, tuple[tuple[str, ...], str | None]]] = {
    "from": {
        "database": ((STRING,), None), "retentionPolicy": ((STRING,), None),
        "measurement": ((STRING,), None), "where": ((LAMBDA,), None),
        "groupBy": ((), STRING), "groupByMeasurement": ((), None),
        "truncate": ((DURATION,), None), "round": ((DURATION,), None),
    },
    "alert": {
        "id": ((STRING,), None), "message": ((STRING,), None), "details": ((STRING,), None),
        "info": ((LAMBDA,), None), "warn": ((LAMBDA,), None), "crit": ((LAMBDA,), None),
        "infoReset": ((LAMBDA,), None), "warnReset": ((LAMBDA,), None),
        "critReset": ((LAMBDA,), None), "stateChangesOnly": ((), DURATION),
        "noRecoveries": ((), None), "all": ((), None), "topic": ((STRING,), None),
        "flapping": ((FLOAT, FLOAT), None), "history": ((INT,), None),
        "levelTag": ((STRING,), None), "levelField": ((STRING,), None),
        "messageField": ((STRING,), None), "durationField": ((STRING,), None),
        "idTag": ((STRING,), None), "idField": ((STRING,), None),
        "category": ((STRING,), None),
        # handlers: chained on the alert (a handler embeds the alert's properties)
        "log": ((STRING,), None), "exec": ((STRING,), STRING), "post": ((), STRING),
        "tcp": ((STRING,), None), "header": ((STRING, STRING), None),
        "timeout": ((DURATION,), None), "mode": ((INT,), None),
    },
    "influxDBOut": {
        "database": ((STRING,), None), "retentionPolicy": ((STRING,), None),
        "measurement": ((STRING,), None), "tag": ((STRING, STRING), None),
        "create": ((), None), "precision": ((STRING,), None), "buffer": ((INT,), None),
        "flushInterval": ((DURATION,), None), "writeConsistency": ((STRING,), None),
    },
}  # fmt: skip
CHILDREN = {"stream": ("from",), "batch": ("query",), "from": ("alert", "where", "eval",
            "window"), "alert": ("influxDBOut",), "influxDBOut": ()}  # fmt: skip
LAMBDA_FUNCTIONS = {"isPresent": 1, "float": 1, "int": 1, "bool": 1, "string": 1, "abs": 1,
                    "sqrt": 1, "floor": 1, "ceil": 1, "pow": 2, "if": 3}  # fmt: skip


def _kind(arg: Any) -> str:
    if isinstance(arg, Lambda):
        return LAMBDA
    if isinstance(arg, Expr):
        if arg.kind == "number":
            return FLOAT if "." in arg.value else INT
        return {"string": STRING, "duration": DURATION}.get(arg.kind, arg.kind)
    return type(arg).__name__


def _accepts(wanted: str, kind: str) -> bool:
    return wanted == kind or (wanted == FLOAT and kind == INT)


def _check_lambda(expr: Expr, where: str) -> None:
    if expr.kind == "ident":
        raise TickError(f'{where}: `{expr.value}` in a lambda: fields are "quoted"')
    if expr.kind == "call":
        call: Call = expr.value
        arity = LAMBDA_FUNCTIONS.get(call.name)
        if arity is None:
            raise TickError(f"{where}: no lambda function `{call.name}`")
        if len(call.args) != arity:
            raise TickError(f"{where}: {call.name}() takes {arity} arguments")
        for arg in call.args:
            _check_lambda(arg, where)
    elif expr.kind == "unary":
        _check_lambda(expr.value[1], where)
    elif expr.kind == "binary":
        _check_lambda(expr.value[1], where)
        _check_lambda(expr.value[2], where)


def _check_property(node: str, call: Call) -> None:
    where = f"{call.line}:{call.column}"
    properties = NODES.get(node, {})
    if call.name not in properties:
        raise TickError(f"{where}: {node} has no property `{call.name}`")
    required, rest = properties[call.name]
    kinds = [_kind(a) for a in call.args]
    if len(kinds) < len(required) or (rest is None and len(kinds) > len(required)):
        raise TickError(f"{where}: .{call.name}() takes {len(required)} arguments")
    wanted_kinds = [*required, *[rest] * (len(kinds) - len(required))]
    for wanted, kind in zip(wanted_kinds, kinds, strict=True):
        if not _accepts(str(wanted), kind):
            raise TickError(f"{where}: .{call.name}() wants a {wanted}, got a {kind}")
    for arg in call.args:
        if isinstance(arg, Lambda):
            _check_lambda(arg.expr, where)


def _follow(chain: Chain, node: str) -> str:
    """Check a chain's steps from the node it starts at; the node it ends at."""
    for sign, call in chain.steps:
        if sign == "|":
            if call.name not in CHILDREN.get(node, ()):
                raise TickError(f"{call.line}:{call.column}: |{call.name}() cannot follow {node}")
            if call.args:
                raise TickError(f"{call.line}:{call.column}: |{call.name}() takes no arguments")
            node = call.name
        elif sign == ".":
            _check_property(node, call)
        else:
            raise TickError(f"{call.line}:{call.column}: no user-defined functions here")
    return node


def check(text: str) -> list[Any]:
    """Parse and validate a script; its statements. A pipeline starts at `stream`
    or `batch`, or at a variable holding one (`var alert = stream|...`)."""
    statements = parse(text)
    nodes: dict[str, str] = {}  # variables holding a pipeline: the node they end at
    pipelines = 0
    for statement in statements:
        chain = statement[-1]
        if statement[0] not in ("var", "expr") or not isinstance(chain, Chain):
            continue
        if chain.head in ("stream", "batch"):
            pipelines += 1
            start = chain.head
        elif chain.head in nodes:
            start = nodes[chain.head]
        else:
            raise TickError(f"a pipeline starts with stream, batch or a variable, not {chain.head}")
        end = _follow(chain, start)
        if statement[0] == "var":
            nodes[statement[1]] = end
    if pipelines != 1:
        raise TickError("a task script holds one pipeline from stream or batch")
    return statements


def strings(statements: list[Any]) -> list[str]:
    """Every string argument's value, as Kapacitor reads it (for quoting tests)."""
    out: list[str] = []
    for statement in statements:
        if statement[0] in ("expr", "var") and isinstance(statement[-1], Chain):
            for _, call in statement[-1].steps:
                out.extend(a.value for a in call.args if isinstance(a, Expr) and a.kind == "string")
    return out
