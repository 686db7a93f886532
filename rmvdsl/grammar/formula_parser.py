"""One formula (or term) given on its own, as `rmv eval` and `rmv sat` take it.

Read without lark where it can be (rmvdsl.grammar.formula_reader); else by the spec
grammar's `formula` rule with the formula builder alone, so that a command reading
one formula loads no declaration's node or rule (a third of its start-up), and
lark's parser words whatever is wrong."""

from __future__ import annotations

from typing import Any, cast

from rmvdsl.grammar.formula import Formula
from rmvdsl.grammar.formula_reader import read_formula
from rmvdsl.lang.diagnostics import Diagnostic, error
from rmvdsl.lang.source import Span


def parse_formula(
    text: str, syntax: str = "auto", path: str = "<formula>", kind: str = "formula"
) -> tuple[Any, list[Diagnostic]]:
    """Parse one formula (or, with kind="term", one term) given on its own."""
    if syntax == "auto":
        syntax = "latex" if "\\" in text else "rmv"
    if syntax == "latex":
        from rmvdsl.grammar import ast
        from rmvdsl.grammar.parser import parse_latex

        literal = ast.StringLit(text, Span(path, -1, len(text) + 1), tuple(range(len(text))))
        return parse_latex(literal, "start" if kind == "formula" else "term")
    read = read_formula(text, path, kind)
    if read is not None:
        return read, []
    return parse_with_lark(text, path, kind)


def parse_with_lark(text: str, path: str, kind: str = "formula") -> tuple[Any, list[Diagnostic]]:
    """The formula (or term) as lark's parser and the formula builder read it."""
    from lark.exceptions import UnexpectedCharacters, UnexpectedToken

    from rmvdsl.grammar.grammars import describe_expected, formula_parser

    parser, builder = formula_parser()
    builder.start_parse(path)
    try:
        formula = parser.parse(text, start=kind)
    except UnexpectedToken as exc:
        token = exc.token
        position = token.start_pos if token.type != "$END" else len(text)
        found = "the end of the formula" if token.type == "$END" else f"`{token}`"
        return None, [
            error(
                "RMV100",
                f"expected {describe_expected(set(exc.expected))}, found {found}",
                Span(path, position or 0, token.end_pos or position or 0),
            )
        ]
    except UnexpectedCharacters as exc:
        position = exc.pos_in_stream or 0
        return None, [
            error(
                "RMV101",
                f"unexpected character `{text[position]}`",
                Span(path, position, position + 1),
            )
        ]
    return cast(Formula, formula), list(builder.diagnostics)
