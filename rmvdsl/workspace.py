"""The front end an editor drives: documents open in it (their unsaved text) over the
files on disk, checked in two steps, and what stands at a position.

`rmv check` and `rmv lsp` both check through a Workspace, so the two never disagree:
the command line's has no open documents. The fast stages (loading, names, types)
answer at once; the solver stages (transducer and property analyses) run after them
and may be abandoned when the text changes again (the editor's `generation`).
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from typing import Any

from rmvdsl.check import CheckResult, check
from rmvdsl.check.loader import read_text
from rmvdsl.check.model import Model, Symbol
from rmvdsl.source import Span

__all__ = ["CheckResult", "Found", "Workspace", "formatted", "references", "symbol_at"]


def _key(path: str) -> str:
    return os.path.normcase(os.path.realpath(path))


class Workspace:
    """Open documents by path; reads prefer them to the disk, imports included."""

    def __init__(self) -> None:
        self._open: dict[str, str] = {}
        self._lock = threading.Lock()

    def open(self, path: str, text: str) -> None:
        with self._lock:
            self._open[_key(path)] = text

    def close(self, path: str) -> None:
        with self._lock:
            self._open.pop(_key(path), None)

    def text(self, path: str) -> str | None:
        with self._lock:
            return self._open.get(_key(path))

    def read(self, path: str) -> str:
        """A file's text: the open document's, else the disk's."""
        text = self.text(path)
        return read_text(path) if text is None else text

    def check(self, path: str, solver: bool = True, **options: Any) -> CheckResult:
        """`rmv check` of `path` as the open documents say it is now."""
        return check(path, self.text(path), read=self.read, solver=solver, **options)


@dataclass(frozen=True)
class Found:
    """What stands at a position: a declared name or a use of one."""

    symbol: Symbol
    span: Span  # the name under the cursor


def symbol_at(model: Model, path: str, offset: int) -> Found | None:
    """The symbol whose declaration or use covers `offset` in `path`."""
    for symbol in model.symbols.values():
        span = symbol.span
        if span.path == path and span.start <= offset <= span.end:
            return Found(symbol, span)
    for reference in model.references:
        span = reference.span
        if span.path == path and span.start <= offset <= span.end:
            return Found(reference.symbol, span)
    return None


def references(model: Model, symbol: Symbol, declaration: bool = True) -> list[Span]:
    """Every span naming `symbol`: its declaration (if asked) and its uses."""
    spans = [r.span for r in model.uses_of(symbol)]
    return [symbol.span, *spans] if declaration else spans


def formatted(path: str, text: str) -> str | None:
    """`rmv fmt` of a text, or None when it has syntax errors (nothing to format)."""
    from rmvdsl.grammar.formatter import format_spec
    from rmvdsl.grammar.parser import parse_source
    from rmvdsl.source import SourceFile

    source = SourceFile(path, text)
    parsed = parse_source(source)
    if any(d.is_error for d in parsed.diagnostics):
        return None
    return format_spec(parsed.spec, source)
