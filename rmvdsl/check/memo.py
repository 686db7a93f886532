"""What checking each declaration found, remembered by the declaration's text, so an
editor's next check reuses it (the names and types stages, when a check is asked to
be incremental).

An edit changes one declaration; the stages used to visit all of them at every
keystroke. A declaration's findings are kept by its file, its text and the spec's
time unit, with what it looked up outside itself (the kind of each name it resolved,
the type of each name it read, the message definitions a variable's path crossed).
They are reused only while every such lookup still gives the same answer, and only
when it had no finding to report: a clean declaration's results are references and
types, and a diagnostic's message could read anything. tests/test_incremental.py
checks every reused answer against a check from scratch.
"""

from __future__ import annotations

from rmvdsl.check.model import Model
from rmvdsl.grammar import ast

# The file, the declaration's text, the spec's time unit (which gives bare numbers
# in formulas a unit).
Key = tuple[str, str, str | None]
# Each stage keeps its findings in a rmvdsl.util.bounded.Bounded of this size at least
# (each check grows it to twice its declarations).
MEMO_SIZE = 50_000


def declaration_key(model: Model, decl: ast.Node) -> Key | None:
    """The key of a declaration: its file, its text, the time unit; None for one
    with a syntax error (its tree may be partial: it is checked each time)."""
    span = decl.span
    source = model.sources.get(span.path)
    if source is None or (model.damaged_ranges.get(span.path) and model.in_damaged(span)):
        return None
    return (span.path, source.text[span.start : span.end], model.time_unit)
