"""InfluxQL expression text to .rmv expression text, token by token (the
author's spacing and parentheses kept), read by the InfluxQL dialect's lexer."""

from __future__ import annotations

import re

from rmvdsl.dialects import influxql
from rmvdsl.grammar.printer import quote

IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_WORDS = ("AND", "OR", "NOT", "TRUE", "FALSE")


def rmv_name(name: str) -> str:
    """A field or tag as an .rmv name: bare where it is an identifier, else quoted."""
    return name if IDENTIFIER.match(name) else quote(name)


def _token(token: influxql.Token) -> str:
    if token.kind == "ident" and token.text.startswith('"'):
        return rmv_name(influxql.value(token))
    if token.kind == "string":
        return quote(influxql.value(token))
    if token.text.upper() in _WORDS:
        return token.text.lower()
    return token.text


def influx_expression(text: str) -> str:
    """An InfluxQL expression in .rmv syntax: quoted identifiers unquoted, keywords
    lower-cased, single-quoted strings double-quoted. A text InfluxQL's lexer
    cannot read is returned as it is (the caller's parse then reports it)."""
    try:
        found = list(influxql.tokens(text))
    except influxql.InfluxQLError:
        return text.strip()
    out: list[str] = []
    end = 0
    for token in found:
        out.append(text[end : token.start] if out else "")
        out.append(_token(token))
        end = token.start + len(token.text)
    return "".join(out).strip()
