"""What checking each declaration found, kept with the declaration's parse, so an
editor's next check reuses it (the names and types stages, when a check is asked to
be incremental).

An edit changes one declaration; the stages used to visit all of them at every
keystroke. The parser keeps each declaration chunk by its file and text
(rmvdsl.grammar.parser) and hands out the same parse, moved to where it now stands,
until the text changes: a declaration's findings are kept in that parse
(rmvdsl.grammar.shift.findings), by Entry, with what it looked up outside itself
(the kind of each name it resolved, the type of each name it read, the message
definitions a variable's path crossed). They are reused only while every such
lookup still gives the same answer, and only when it had no finding to report: a
clean declaration's results are references and types, and a diagnostic's message
could read anything.
A declaration with a syntax error keeps nothing (its tree may be partial: it is
checked each time). tests/test_incremental.py checks every reused answer against a
check from scratch.
"""

from __future__ import annotations

# A stage's entry: the stage, the spec's time unit (which gives bare numbers in
# formulas a unit).
Entry = tuple[str, str | None]
