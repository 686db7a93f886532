"""What the language server's features look up in its checks: the check of a
document's text as it is now (waiting for its fast stages), the newest one, what
stands at a position, where a span is. The base of RmvServer
(rmvdsl.editor.lsp.session, which keeps the checks up to date)."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

from lsprotocol import types
from pygls.lsp.server import LanguageServer
from pygls.workspace import TextDocument

from rmvdsl.check.model import Model, Symbol
from rmvdsl.editor.lsp import convert
from rmvdsl.editor.lsp.state import State
from rmvdsl.editor.mentions import Mention, mention_at, mentions
from rmvdsl.editor.workspace import CheckResult, symbol_at
from rmvdsl.lang.source import Span

# How long a request waits for the check of the text it was sent against (an
# editor asks for hover, tokens and folds right after didOpen): the fast stages of
# a 20,000-line spec take seconds, a hung check must not hang the request too.
ANALYSIS_WAIT = 30.0


class Lookups(LanguageServer):
    """pygls's server with the lookups of RmvServer (its subclass, which keeps
    `state` up to date): its documents, and what is in their checks."""

    state: State

    def document(self, uri: str) -> TextDocument:
        return self.workspace.get_text_document(uri)

    def open_documents(self) -> dict[str, TextDocument]:
        return {d.path: d for d in self.workspace.text_documents.values()}

    @property
    def encoding(self) -> str:
        """The position encoding the client negotiated ("utf-16" unless it asked
        for another), as the plain string every conversion compares with: pygls
        gives an enum member when the client named none, and str() of that is
        its Python name."""
        chosen = self.workspace.position_encoding or types.PositionEncodingKind.Utf16
        return str(getattr(chosen, "value", chosen))

    def location(self, model: Model, span: Span) -> types.Location | None:
        source = model.sources.get(span.path)
        if source is None:
            return None
        return types.Location(
            convert.uri_of(span.path), convert.lsp_range(source, span, self.encoding)
        )

    async def analysed(self, uri: str) -> CheckResult | None:
        """The check of the document's text as it is now, once its fast stages are
        published: a request sent right after a change is answered for the text it
        was sent against, not with nothing."""
        path = self.document(uri).path
        waiter = self.state.analysed.get(path)
        if waiter is not None and not waiter.done():
            await asyncio.wait({waiter}, timeout=ANALYSIS_WAIT)
        return self.checked(uri)

    async def latest(self, uri: str) -> CheckResult | None:
        """The check of the text as it is now, else the newest check of the
        document (an outline may show a moment-old text's declarations)."""
        found = await self.analysed(uri)
        return found or self.state.results.get(self.document(uri).path)

    async def all_analysed(self) -> None:
        """Wait until every open document's newest text has been checked."""
        waiting = {w for w in self.state.analysed.values() if not w.done()}
        if waiting:
            await asyncio.wait(waiting, timeout=ANALYSIS_WAIT)

    def checked(self, uri: str) -> CheckResult | None:
        """The newest check of a document, if it checked the text shown now."""
        document = self.document(uri)
        result = self.state.results.get(document.path)
        if result is None:
            return None
        source = result.model.sources.get(document.path)
        if source is None or source.text != document.source:
            return None  # a check of this text has not finished yet
        return result

    def mentions_of(self, result: CheckResult) -> list[Mention]:
        """The mentions of a check, found once per check of its root file."""
        root = result.model.specs[0].path if result.model.specs else ""
        cached = self.state.mentions.get(root)
        if cached is None or cached[0] is not result:
            cached = self.state.mentions[root] = (result, mentions(result))
        return cached[1]

    async def target_at(self, uri: str, position: types.Position) -> Target | None:
        """The symbol or the mention at a position of a checked document."""
        result = await self.analysed(uri)
        if result is None:
            return None
        document = self.document(uri)
        offset = convert.offset_at(document, position)
        found = symbol_at(result.model, document.path, offset)
        if found is not None:
            return Target(result, found.symbol, None)
        mention = mention_at(self.mentions_of(result), document.path, offset)
        return None if mention is None else Target(result, None, mention)

    async def found_at(self, uri: str, position: types.Position) -> tuple[Model, Symbol] | None:
        target = await self.target_at(uri, position)
        if target is None or target.symbol is None:
            return None
        return target.result.model, target.symbol


@dataclass(frozen=True)
class Target:
    """What a request points at: a declared name or another mention."""

    result: CheckResult
    symbol: Symbol | None
    mention: Mention | None
