"""InfluxQL expression text to .rmv expression text."""

from __future__ import annotations

import re

from rmvdsl.grammar.printer import quote

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def influx_expression(text: str) -> str:
    """An InfluxQL expression in .rmv syntax: quoted identifiers unquoted, keywords
    lower-cased, single-quoted strings double-quoted."""
    out = []
    for token in re.finditer(r'"([^"]*)"|\'([^\']*)\'|([A-Za-z_][A-Za-z0-9_]*)|(\S)|(\s+)', text):
        double, single, word, other, space = token.groups()
        if double is not None:
            out.append(double if _IDENT.match(double) else quote(double))
        elif single is not None:
            out.append(quote(single))
        elif word is not None:
            out.append(
                word.lower() if word.upper() in ("AND", "OR", "NOT", "TRUE", "FALSE") else word
            )
        else:
            out.append(other if other is not None else space)
    return "".join(out).strip()
