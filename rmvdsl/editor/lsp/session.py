"""The language server's state: its documents, the workspace and the newest check
of each, and the lookups every feature shares (what is at a position, where a span
is); diagnostics published as `rmv check` gives them."""

from __future__ import annotations

import asyncio
import functools
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from lsprotocol import types
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol
from pygls.workspace import TextDocument

from rmvdsl import __version__
from rmvdsl.check.model import Model, Symbol
from rmvdsl.editor.lsp import convert
from rmvdsl.editor.mentions import Mention, mention_at, mentions
from rmvdsl.editor.workspace import (
    CheckResult,
    Workspace,
    symbol_at,
)
from rmvdsl.lang.source import Span

DEBOUNCE = 0.3  # seconds of quiet before the solver stages run


@dataclass
class State:
    """The server's view: the workspace, each document's change count, and the
    newest check of each document."""

    # Incremental: a keystroke re-checks only what it could change.
    workspace: Workspace = field(default_factory=lambda: Workspace(incremental=True))
    generation: dict[str, int] = field(default_factory=dict)
    results: dict[str, CheckResult] = field(default_factory=dict)
    pool: ThreadPoolExecutor = field(default_factory=lambda: ThreadPoolExecutor(2))
    published: dict[str, set[str]] = field(default_factory=dict)  # root -> paths shown
    mentions: dict[str, tuple[CheckResult, list[Mention]]] = field(default_factory=dict)


class Protocol(LanguageServerProtocol):
    """pygls's protocol, keeping no finished handler.

    pygls 2.1 files the future of every handler it runs under its message id, and
    only a request's answer takes it out: each notification's (two per didChange)
    stayed for the life of the server, about 2 KB an edit (found with tracemalloc
    over 1,000 edits). Here a future leaves the table once it is done, in the next
    turn of the event loop: pygls's shutdown cancels futures while iterating the
    table, and a cancelled future runs its callbacks at once."""

    def _execute_handler(self, msg_id: Any, *args: Any, **kwargs: Any) -> None:
        super()._execute_handler(msg_id, *args, **kwargs)
        future = self._request_futures.get(msg_id)
        if future is not None:
            loop = asyncio.get_running_loop()  # messages are handled on the loop
            future.add_done_callback(
                lambda done: loop.call_soon_threadsafe(self._forget, msg_id, done)
            )

    def _forget(self, msg_id: Any, future: Any) -> None:
        if self._request_futures.get(msg_id) is future:
            del self._request_futures[msg_id]


class RmvServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__(
            "rmv-lsp",
            __version__,
            protocol_cls=Protocol,
            text_document_sync_kind=types.TextDocumentSyncKind.Incremental,
        )
        self.state = State()

    def document(self, uri: str) -> TextDocument:
        return self.workspace.get_text_document(uri)

    def open_documents(self) -> dict[str, TextDocument]:
        return {d.path: d for d in self.workspace.text_documents.values()}

    @property
    def encoding(self) -> str:
        """The position encoding the client negotiated."""
        return str(self.workspace.position_encoding or types.PositionEncodingKind.Utf16)

    async def refresh(self, uri: str) -> None:
        """Check a document: the fast stages, then (if nothing changed meanwhile)
        the solver stages; publish each unless a newer change overtook it."""
        document = self.document(uri)
        path, state = document.path, self.state
        state.workspace.open(path, document.source)
        generation = state.generation[path] = state.generation.get(path, 0) + 1
        loop = asyncio.get_running_loop()
        fast = functools.partial(state.workspace.check, path, solver=False)
        result = await loop.run_in_executor(state.pool, fast)
        if state.generation.get(path) != generation:
            return
        self.publish(path, result)
        await asyncio.sleep(DEBOUNCE)
        if state.generation.get(path) != generation:
            return
        result = await loop.run_in_executor(state.pool, state.workspace.check, path)
        if state.generation.get(path) == generation:
            self.publish(path, result)

    def publish(self, root: str, result: CheckResult) -> None:
        """The diagnostics of a check, per file (an import's show in that file)."""
        self.state.results[root] = result
        documents = self.open_documents()
        by_path: dict[str, list[types.Diagnostic]] = {root: []}
        for found in result.diagnostics:
            converted = convert.diagnostic(found, result.model.sources, self.encoding)
            if converted is not None:
                by_path.setdefault(found.span.path, []).append(converted)
        for stale in self.state.published.get(root, set()) - set(by_path):
            by_path[stale] = []
        self.state.published[root] = {p for p, items in by_path.items() if items}
        for path, items in by_path.items():
            version = documents[path].version if path in documents else None
            self.text_document_publish_diagnostics(
                types.PublishDiagnosticsParams(
                    uri=convert.uri_of(path), diagnostics=items, version=version
                )
            )

    def location(self, model: Model, span: Span) -> types.Location | None:
        source = model.sources.get(span.path)
        if source is None:
            return None
        return types.Location(
            convert.uri_of(span.path), convert.lsp_range(source, span, self.encoding)
        )

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

    def target_at(self, uri: str, position: types.Position) -> Target | None:
        """The symbol or the mention at a position of a checked document."""
        result = self.checked(uri)
        if result is None:
            return None
        document = self.document(uri)
        offset = convert.offset_at(document, position)
        found = symbol_at(result.model, document.path, offset)
        if found is not None:
            return Target(result, found.symbol, None)
        mention = mention_at(self.mentions_of(result), document.path, offset)
        return None if mention is None else Target(result, None, mention)

    def found_at(self, uri: str, position: types.Position) -> tuple[Model, Symbol] | None:
        target = self.target_at(uri, position)
        if target is None or target.symbol is None:
            return None
        return target.result.model, target.symbol


@dataclass(frozen=True)
class Target:
    """What a request points at: a declared name or another mention."""

    result: CheckResult
    symbol: Symbol | None
    mention: Mention | None
