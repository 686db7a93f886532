"""Reading TICKscript: its tokens, and a parser for `rmv import` (the thesis's
alert scripts): `dbrp`, `var`, pipelines and their arguments as the tree."""

from __future__ import annotations

from collections.abc import Iterator

from rmvdsl.dialects.common import (
    Cursor,
    Lexicon,
    Token,
    climb,
    nesting_refused,
    quoted_end,
    scan,
)
from rmvdsl.dialects.tickscript.syntax import (
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

_DURATION_UNITS = ("ms", "u", "µ", "s", "m", "h", "d", "w")


def _quoted(text: str, start: int) -> tuple[str, int]:
    if text.startswith("'''", start):
        end = text.find("'''", start + 3)
        if end < 0:
            raise TickError(f"unclosed ''' at offset {start}")
        return "string", end + 3
    kind = "string" if text[start] == "'" else "reference"
    stop = "\n" if kind == "reference" else ""
    return kind, quoted_end(text, start, TickError, stop=stop, only_quote=True)


def _number(text: str, start: int) -> tuple[str, int]:
    index = start
    while index < len(text) and (text[index].isdigit() or text[index] == "."):
        index += 1
    unit = next((u for u in _DURATION_UNITS if text.startswith(u, index)), None)
    after = index + len(unit or "")
    if unit and not (after < len(text) and (text[after].isalnum() or text[after] == "_")):
        return "duration", after
    return "number", index


LEXICON = Lexicon(
    comment="//", quoted=_quoted, number=_number, word=lambda word: "word",
    operators=("==", "!=", "<=", ">=", "=~", "!~", "<", ">", "+", "-", "*", "/", "%", "!", "="),
    punctuation="|.@(),:", error=TickError,
)  # fmt: skip


def tokens(text: str) -> Iterator[Token]:
    """The tokens of a script; whitespace and `//` comments skipped."""
    return scan(text, LEXICON)


def value(token: Token) -> str:
    """A string's or a reference's meaning (a word: itself)."""
    if token.kind == "string" and token.text.startswith("'''"):
        return token.text[3:-3]
    if token.kind in ("string", "reference"):
        quote = token.text[0]
        return token.text[1:-1].replace("\\" + quote, quote)
    return token.text


# ---- the parser ----


# Kapacitor's binding strengths (tick/ast/node.go, `precedence`), weakest first.
BINDING = (("OR",), ("AND",), ("==", "!=", "<", "<=", ">", ">=", "=~", "!~"), ("+", "-"),
           ("*", "/", "%"))  # fmt: skip


class _Reader(Cursor):
    def __init__(self, text: str) -> None:
        super().__init__(list(tokens(text)), TickError, "script", fold=False)


def _expression(reader: _Reader) -> Expr:
    result: Expr = climb(reader, BINDING, lambda: _unary(reader))
    return result


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
        return Text(value(token))
    if token.kind == "reference":
        return Reference(value(token))
    if token.kind in ("number", "duration") or token.text in ("TRUE", "FALSE"):
        return Literal(token.text)
    if token.kind == "word" and token.text == "lambda":
        reader.expect(":")
        return Lambda(_expression(reader))
    if token.kind == "word":
        if reader.take("("):
            return Call(token.text, _arguments(reader))
        return Identifier(token.text)
    raise reader.unexpected(token)


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
    return Pipeline(value(source), tuple(steps), var)


def _at_pipeline(reader: _Reader) -> bool:
    """A pipeline starts with a word (`stream`, `batch`, a variable) that a step follows."""
    first, second = reader.peek(), reader.peek(1)
    if first is None or first.kind != "word" or first.text == "lambda":
        return False
    return first.text in ("stream", "batch") or (second is not None and second.text in "|.@")


@nesting_refused(TickError)
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
            found.append(Dbrp(value(database), value(retention)))
        elif reader.take("var"):
            name = reader.next("a name").text
            reader.expect("=")
            found.append(_pipeline(reader, name) if _at_pipeline(reader) else
                         Var(name, _expression(reader)))  # fmt: skip
        else:
            found.append(_pipeline(reader, None))
    return found
