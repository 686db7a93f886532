"""What the dialects share: the expression nodes both languages have (literals,
strings, operators, calls), tokens and the scanner loop (each dialect gives its
comments, quotes, numbers and words), a cursor over tokens, and precedence
climbing over a dialect's table of binding strengths."""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

# ---- nodes ----


@dataclass(frozen=True)
class Literal:
    """A number, boolean or duration, as the dialect writes it."""

    text: str


@dataclass(frozen=True)
class Text:
    """A string literal's value."""

    value: str


@dataclass(frozen=True)
class Binary:
    op: str
    left: Any  # a node of the dialect's tree
    right: Any


@dataclass(frozen=True)
class Unary:
    op: str  # `-`, or TICKscript's `!`
    operand: Any


@dataclass(frozen=True)
class Call:
    function: str
    args: tuple[Any, ...]


def printed(expr: Any, own: Callable[[Any], str | None], string: Callable[[str], str]) -> str:
    """An expression as a dialect writes it, operands parenthesised so the tree is the
    one printed whatever the dialect's precedence: `own` prints the dialect's own
    nodes (names, references, lambdas; None for the shared ones), `string` quotes."""

    def show(node: Any) -> str:
        text = own(node)
        if text is not None:
            return text
        match node:
            case Literal():
                return node.text
            case Text():
                return string(node.value)
            case Unary():
                return f"{node.op}{operand(node.operand)}"
            case Binary():
                return f"{operand(node.left)} {node.op} {operand(node.right)}"
            case Call():
                return f"{node.function}({', '.join(show(a) for a in node.args)})"
        raise TypeError(f"not a node: {node!r}")

    def operand(node: Any) -> str:
        text = show(node)
        return f"({text})" if isinstance(node, (Binary, Unary)) else text

    return show(expr)


# ---- tokens ----


@dataclass(frozen=True)
class Token:
    kind: str
    text: str  # as written
    start: int  # its offset in the text


@dataclass(frozen=True)
class Lexicon:
    """A dialect's tokens: `quoted(text, start)` and `number(text, start)` give a
    token's kind and end; `word(text)` a word's kind."""

    comment: str
    quoted: Callable[[str, int], tuple[str, int]]
    number: Callable[[str, int], tuple[str, int]]
    word: Callable[[str], str]
    operators: tuple[str, ...]  # longest first where one begins another
    punctuation: str
    error: type[ValueError]


def scan(text: str, lexicon: Lexicon) -> Iterator[Token]:
    """The tokens of a text; whitespace and comments skipped."""
    index = 0
    while index < len(text):
        char = text[index]
        if char.isspace():
            index += 1
            continue
        if text.startswith(lexicon.comment, index):
            end = text.find("\n", index)
            index = len(text) if end < 0 else end
            continue
        if char in "'\"":
            kind, end = lexicon.quoted(text, index)
        elif char.isdigit():
            kind, end = lexicon.number(text, index)
        elif char.isalpha() or char == "_":
            end = index
            while end < len(text) and (text[end].isalnum() or text[end] == "_"):
                end += 1
            kind = lexicon.word(text[index:end])
        elif op := next((o for o in lexicon.operators if text.startswith(o, index)), None):
            kind, end = "op", index + len(op)
        elif char in lexicon.punctuation:
            kind, end = "punct", index + 1
        else:
            raise lexicon.error(f"unexpected {char!r} at offset {index}")
        yield Token(kind, text[index:end], index)
        index = end


def quoted_end(
    text: str, start: int, error: type[ValueError], stop: str = "", only_quote: bool = False
) -> int:
    """The index after the quote closing the literal opened at `start`: a backslash
    escapes the next character (with `only_quote`, only the quote itself, as
    Kapacitor's lexer reads); a character of `stop` ends it unclosed."""
    index = start + 1
    while index < len(text):
        if text[index] == "\\" and (not only_quote or text[index + 1 : index + 2] == text[start]):
            index += 2
            continue
        if text[index] == text[start]:
            return index + 1
        if text[index] in stop:
            break
        index += 1
    raise error(f"unclosed {text[start]} at offset {start}")


# ---- parsing ----


def nesting_refused(error: type[ValueError]) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """A reader whose recursion (parentheses, unary signs, lambdas in each other)
    runs out of stack raises the dialect's `error` instead: what no server would
    accept either, said in words (found by fuzzing the TICKscript importer)."""

    def wrap(read: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(read)
        def reading(*args: Any, **kwargs: Any) -> Any:
            try:
                return read(*args, **kwargs)
            except RecursionError:
                raise error("nested too deeply to read (parentheses or signs)") from None

        return reading

    return wrap


class Cursor:
    """Tokens with look-ahead, and errors that say what was expected and where.
    `fold`: keywords match whatever their case (InfluxQL's)."""

    def __init__(self, tokens: list[Token], error: type[ValueError], end: str, fold: bool) -> None:
        self.items, self.error, self.end, self.fold = tokens, error, end, fold
        self.index = 0

    def peek(self, ahead: int = 0) -> Token | None:
        at = self.index + ahead
        return self.items[at] if at < len(self.items) else None

    def next(self, what: str) -> Token:
        token = self.peek()
        if token is None:
            raise self.error(f"expected {what}, found the end of the {self.end}")
        self.index += 1
        return token

    def at(self, *words: str) -> bool:
        for ahead, word in enumerate(words):
            token = self.peek(ahead)
            if token is None or token.kind in ("string", "number", "duration", "reference"):
                return False
            if (token.text.upper() if self.fold else token.text) != word:
                return False
        return True

    def take(self, *words: str) -> bool:
        if self.at(*words):
            self.index += len(words)
            return True
        return False

    def expect(self, *words: str) -> None:
        if not self.take(*words):
            raise self.error(f"expected `{' '.join(words)}`, found {self.where()}")

    def where(self) -> str:
        token = self.peek()
        return f"`{token.text}` at offset {token.start}" if token else "the end"

    def unexpected(self, token: Token) -> ValueError:
        return self.error(f"unexpected `{token.text}` at offset {token.start}")


def climb(cursor: Cursor, levels: tuple[tuple[str, ...], ...], operand: Callable[[], Any],
          level: int = 0) -> Any:  # fmt: skip
    """Binary operators by binding strength (`levels`, weakest first), each level
    binding to the left; `operand()` reads what the strongest level joins."""
    if level == len(levels):
        return operand()
    left = climb(cursor, levels, operand, level + 1)
    while (
        (token := cursor.peek()) is not None
        and token.kind in ("op", "keyword", "word")
        and ((token.text.upper() if cursor.fold else token.text) in levels[level])
    ):
        cursor.index += 1
        op = token.text.upper() if cursor.fold else token.text
        left = Binary(op, left, climb(cursor, levels, operand, level + 1))
    return left
