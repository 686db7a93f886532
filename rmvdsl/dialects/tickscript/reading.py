"""Reading TICKscript: its tokens, and a parser for `rmv import` (the thesis's
alert scripts): `dbrp`, `var`, pipelines and their arguments as the tree."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from rmvdsl.dialects.tickscript.syntax import (
    Binary,
    Call,
    Dbrp,
    Expr,
    Identifier,
    Lambda,
    Literal,
    Pipeline,
    Reference,
    Statement,
    Step,
    Text,
    TickError,
    Unary,
    Var,
)

# ---- tokens ----


@dataclass(frozen=True)
class Token:
    kind: str  # string, reference, number, duration, word, op, punct
    text: str
    start: int

    @property
    def value(self) -> str:
        """A string's or a reference's meaning."""
        if self.kind == "string" and self.text.startswith("'''"):
            return self.text[3:-3]
        if self.kind in ("string", "reference"):
            quote = self.text[0]
            return self.text[1:-1].replace("\\" + quote, quote)
        return self.text


_OPERATORS = ("==", "!=", "<=", ">=", "=~", "!~", "<", ">", "+", "-", "*", "/", "%", "!", "=")
_PUNCT = "|.@(),:"
_DURATION_UNITS = ("ms", "u", "µ", "s", "m", "h", "d", "w")


def _quoted_end(text: str, start: int) -> int:
    if text.startswith("'''", start):
        end = text.find("'''", start + 3)
        if end < 0:
            raise TickError(f"unclosed ''' at offset {start}")
        return end + 3
    index = start + 1
    while index < len(text):
        if text[index] == "\\":
            index += 2
            continue
        if text[index] == text[start]:
            return index + 1
        if text[index] == "\n" and text[start] == '"':
            break
        index += 1
    raise TickError(f"unclosed {text[start]} at offset {start}")


def _number(text: str, start: int) -> Token:
    index = start
    while index < len(text) and (text[index].isdigit() or text[index] == "."):
        index += 1
    unit = next((u for u in _DURATION_UNITS if text.startswith(u, index)), None)
    after = index + len(unit or "")
    if unit and not (after < len(text) and (text[after].isalnum() or text[after] == "_")):
        return Token("duration", text[start:after], start)
    return Token("number", text[start:index], start)


def tokens(text: str) -> Iterator[Token]:
    """The tokens of a script; whitespace and `//` comments skipped."""
    index = 0
    while index < len(text):
        char = text[index]
        if char.isspace():
            index += 1
        elif text.startswith("//", index):
            end = text.find("\n", index)
            index = len(text) if end < 0 else end
        elif char in "'\"":
            end = _quoted_end(text, index)
            yield Token("string" if char == "'" else "reference", text[index:end], index)
            index = end
        elif char.isdigit():
            token = _number(text, index)
            yield token
            index += len(token.text)
        elif char.isalpha() or char == "_":
            end = index
            while end < len(text) and (text[end].isalnum() or text[end] == "_"):
                end += 1
            yield Token("word", text[index:end], index)
            index = end
        elif op := next((o for o in _OPERATORS if text.startswith(o, index)), None):
            yield Token("op", op, index)
            index += len(op)
        elif char in _PUNCT:
            yield Token("punct", char, index)
            index += 1
        else:
            raise TickError(f"unexpected {char!r} at offset {index}")


# ---- the parser ----


# Kapacitor's binding strengths (tick/ast/node.go, `precedence`), weakest first.
BINDING = (("OR",), ("AND",), ("==", "!=", "<", "<=", ">", ">=", "=~", "!~"), ("+", "-"),
           ("*", "/", "%"))  # fmt: skip


class _Reader:
    def __init__(self, text: str) -> None:
        self.items = list(tokens(text))
        self.index = 0

    def peek(self, ahead: int = 0) -> Token | None:
        at = self.index + ahead
        return self.items[at] if at < len(self.items) else None

    def next(self, what: str) -> Token:
        token = self.peek()
        if token is None:
            raise TickError(f"expected {what}, found the end of the script")
        self.index += 1
        return token

    def take(self, text: str) -> bool:
        token = self.peek()
        if token is not None and token.text == text and token.kind in ("punct", "op", "word"):
            self.index += 1
            return True
        return False

    def expect(self, text: str) -> None:
        if not self.take(text):
            token = self.peek()
            where = f"`{token.text}` at offset {token.start}" if token else "the end"
            raise TickError(f"expected `{text}`, found {where}")


def _expression(reader: _Reader, level: int = 0) -> Expr:
    if level == len(BINDING):
        return _unary(reader)
    left = _expression(reader, level + 1)
    while (token := reader.peek()) is not None and token.text in BINDING[level]:
        reader.index += 1
        left = Binary(token.text, left, _expression(reader, level + 1))
    return left


def _unary(reader: _Reader) -> Expr:
    token = reader.peek()
    if token is not None and token.text in ("-", "!"):
        reader.index += 1
        return Unary(token.text, _unary(reader))
    return _primary(reader)


def _primary(reader: _Reader) -> Expr:
    token = reader.next("an expression")
    if token.text == "(" and token.kind == "punct":
        inner = _expression(reader)
        reader.expect(")")
        return inner
    if token.kind == "string":
        return Text(token.value)
    if token.kind == "reference":
        return Reference(token.value)
    if token.kind in ("number", "duration") or token.text in ("TRUE", "FALSE"):
        return Literal(token.text)
    if token.kind == "word" and token.text == "lambda":
        reader.expect(":")
        return Lambda(_expression(reader))
    if token.kind == "word":
        if reader.take("("):
            return Call(token.text, _arguments(reader))
        return Identifier(token.text)
    raise TickError(f"unexpected `{token.text}` at offset {token.start}")


def _arguments(reader: _Reader) -> tuple[Expr, ...]:
    """The arguments after an opening parenthesis, through the closing one."""
    args: list[Expr] = []
    while not reader.take(")"):
        if args:
            reader.expect(",")
        args.append(_expression(reader))
    return tuple(args)


def _pipeline(reader: _Reader, var: str | None) -> Pipeline:
    source = reader.next("a pipeline")
    steps = []
    while (token := reader.peek()) is not None and token.text in ("|", ".", "@"):
        reader.index += 1
        name = reader.next("a node or property")
        if name.kind != "word":
            raise TickError(f"expected a name after `{token.text}` at offset {token.start}")
        reader.expect("(")
        steps.append(Step(token.text, name.text, _arguments(reader)))
    return Pipeline(source.value if source.kind == "reference" else source.text, tuple(steps), var)


def _at_pipeline(reader: _Reader) -> bool:
    """A pipeline starts with a word (`stream`, `batch`, a variable) that a step follows."""
    first, second = reader.peek(), reader.peek(1)
    if first is None or first.kind != "word" or first.text == "lambda":
        return False
    return first.text in ("stream", "batch") or (second is not None and second.text in "|.@")


def parse(script: str) -> list[Statement]:
    """The statements of a script: `dbrp`, `var`, pipelines.
    TickError names what is malformed."""
    reader = _Reader(script)
    found: list[Statement] = []
    while reader.peek() is not None:
        if reader.take("dbrp"):
            database = reader.next("a database")
            reader.expect(".")
            retention = reader.next("a retention policy")
            found.append(Dbrp(database.value, retention.value))
        elif reader.take("var"):
            name = reader.next("a name").text
            reader.expect("=")
            found.append(_pipeline(reader, name) if _at_pipeline(reader) else
                         Var(name, _expression(reader)))  # fmt: skip
        else:
            found.append(_pipeline(reader, None))
    return found
