"""`rmv lsp`: a language server over stdio (pygls 2), thin over rmvdsl.editor.workspace.

Every feature is registered in `build()`. Diagnostics are exactly `rmv check`'s:
the fast stages (loading, names, types) are published as soon as a change is read,
the solver stages after the text has rested for `DEBOUNCE` seconds; a result that
a newer change has overtaken is never published.
"""

from __future__ import annotations

import asyncio
import functools
import gc
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from lsprotocol import types
from pygls.exceptions import JsonRpcInvalidParams
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol
from pygls.workspace import TextDocument

from rmvdsl import __version__
from rmvdsl.check.model import Kind, Model, Symbol
from rmvdsl.editor.lsp import convert
from rmvdsl.editor.mentions import Mention, describe, mention_at, mentions, same
from rmvdsl.editor.workspace import (
    TOKEN_TYPES,
    CheckResult,
    Workspace,
    completions,
    details,
    folds,
    formatted,
    references,
    rename,
    semantic_tokens,
    symbol_at,
)
from rmvdsl.lang.source import Span

DEBOUNCE = 0.3  # seconds of quiet before the solver stages run
COMPLETION_KINDS = {
    "keyword": types.CompletionItemKind.Keyword,
    "function": types.CompletionItemKind.Function,
    "setting": types.CompletionItemKind.Property,
    "value": types.CompletionItemKind.EnumMember,
    "message": types.CompletionItemKind.Struct,
    "field": types.CompletionItemKind.Field,
    "constant": types.CompletionItemKind.Constant,
    Kind.TOPIC.value: types.CompletionItemKind.Interface,
    Kind.VARIABLE.value: types.CompletionItemKind.Variable,
    Kind.VALUE_EVENT.value: types.CompletionItemKind.Event,
    Kind.BOOL_EVENT.value: types.CompletionItemKind.Event,
    Kind.EMITTED_EVENT.value: types.CompletionItemKind.Event,
    Kind.ALERT.value: types.CompletionItemKind.Constant,
    Kind.TRANSDUCER.value: types.CompletionItemKind.Class,
    Kind.STATE.value: types.CompletionItemKind.EnumMember,
    Kind.PROPERTY.value: types.CompletionItemKind.Property,
}
SYMBOL_KINDS = {
    Kind.TOPIC: types.SymbolKind.Interface,
    Kind.VARIABLE: types.SymbolKind.Variable,
    Kind.VALUE_EVENT: types.SymbolKind.Event,
    Kind.BOOL_EVENT: types.SymbolKind.Event,
    Kind.EMITTED_EVENT: types.SymbolKind.Event,
    Kind.ALERT: types.SymbolKind.Constant,
    Kind.TRANSDUCER: types.SymbolKind.Class,
    Kind.STATE: types.SymbolKind.EnumMember,
    Kind.PROPERTY: types.SymbolKind.Property,
}


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


def build() -> RmvServer:
    """The server with every feature registered."""
    server = RmvServer()

    @server.feature(types.TEXT_DOCUMENT_DID_OPEN)
    async def did_open(ls: RmvServer, params: types.DidOpenTextDocumentParams) -> None:
        await ls.refresh(params.text_document.uri)
        # What a first check built (parsed declarations, message definitions) lives
        # as long as the document: kept out of the collector's full sweeps, which
        # otherwise stall one keystroke in twenty by 50 ms on a 2,000-line spec.
        # Unfrozen first, so what earlier documents left behind is collected, not
        # kept for ever. (Only `rmv lsp`'s own process builds this server.)
        gc.unfreeze()
        gc.collect()
        gc.freeze()

    @server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
    async def did_change(ls: RmvServer, params: types.DidChangeTextDocumentParams) -> None:
        await ls.refresh(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_SAVE)
    async def did_save(ls: RmvServer, params: types.DidSaveTextDocumentParams) -> None:
        await ls.refresh(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: RmvServer, params: types.DidCloseTextDocumentParams) -> None:
        path = ls.document(params.text_document.uri).path
        ls.state.workspace.close(path)
        ls.state.generation[path] = ls.state.generation.get(path, 0) + 1

    @server.feature(types.TEXT_DOCUMENT_HOVER)
    def hover(ls: RmvServer, params: types.HoverParams) -> types.Hover | None:
        target = ls.target_at(params.text_document.uri, params.position)
        if target is None:
            return None
        result, symbol = target.result, target.symbol
        if symbol is not None:
            text = hover_text(result.model, symbol, details(result, symbol))
        else:
            assert target.mention is not None
            text = describe(result, target.mention)
        return types.Hover(contents=types.MarkupContent(types.MarkupKind.Markdown, text))

    @server.feature(types.TEXT_DOCUMENT_DEFINITION)
    def definition(ls: RmvServer, params: types.DefinitionParams) -> types.Location | None:
        target = ls.target_at(params.text_document.uri, params.position)
        if target is None:
            return None
        model = target.result.model
        if target.symbol is not None:
            return ls.location(model, target.symbol.span)
        where = target.mention.target if target.mention is not None else None
        return None if where is None else ls.location(model, where)

    @server.feature(types.TEXT_DOCUMENT_REFERENCES)
    def find_references(ls: RmvServer, params: types.ReferenceParams) -> list[types.Location]:
        target = ls.target_at(params.text_document.uri, params.position)
        if target is None:
            return []
        model, declared = target.result.model, params.context.include_declaration
        if target.symbol is not None:
            spans = references(model, target.symbol, declared)
        else:
            assert target.mention is not None
            alike = same(ls.mentions_of(target.result), target.mention)
            spans = [m.span for m in alike if not m.declares]
            where = target.mention.target
            if declared and where is not None and where not in spans:
                spans.insert(0, where)
        return [location for span in spans if (location := ls.location(model, span))]

    @server.feature(types.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def document_symbols(
        ls: RmvServer, params: types.DocumentSymbolParams
    ) -> list[types.DocumentSymbol]:
        document = ls.document(params.text_document.uri)
        result = ls.state.results.get(document.path)
        if result is None:
            return []
        return outline(result.model, document.path, ls.encoding)

    @server.feature(
        types.TEXT_DOCUMENT_COMPLETION, types.CompletionOptions(trigger_characters=["=", " "])
    )
    def complete(ls: RmvServer, params: types.CompletionParams) -> types.CompletionList:
        document = ls.document(params.text_document.uri)
        result = ls.state.results.get(document.path)
        offset = convert.offset_at(document, params.position)
        items = [
            types.CompletionItem(
                label=c.label,
                kind=COMPLETION_KINDS.get(c.kind),
                detail=c.detail,
                documentation=c.doc or None,
            )
            for c in completions(result, document.source, offset)
        ]
        return types.CompletionList(is_incomplete=False, items=items)

    @server.feature(types.TEXT_DOCUMENT_RENAME)
    def rename_symbol(ls: RmvServer, params: types.RenameParams) -> types.WorkspaceEdit | None:
        found = ls.found_at(params.text_document.uri, params.position)
        if found is None:
            return None
        model, symbol = found
        try:
            spans = rename(model, symbol, params.new_name)
        except ValueError as why:
            raise JsonRpcInvalidParams(str(why)) from None
        changes: dict[str, list[types.TextEdit]] = {}
        for span in spans:
            location = ls.location(model, span)
            if location is not None:
                edit = types.TextEdit(range=location.range, new_text=params.new_name)
                changes.setdefault(location.uri, []).append(edit)
        return types.WorkspaceEdit(changes=changes)

    @server.feature(
        types.TEXT_DOCUMENT_CODE_ACTION,
        types.CodeActionOptions(code_action_kinds=[types.CodeActionKind.QuickFix]),
    )
    def code_actions(ls: RmvServer, params: types.CodeActionParams) -> list[types.CodeAction]:
        """The fixes of the diagnostics in the range (each says what its help says)."""
        actions = []
        for found in params.context.diagnostics:
            for title, uri, edit in convert.edits_of(found):
                actions.append(
                    types.CodeAction(
                        title=title,
                        kind=types.CodeActionKind.QuickFix,
                        diagnostics=[found],
                        edit=types.WorkspaceEdit(changes={uri: [edit]}),
                        is_preferred=True,
                    )
                )
        return actions

    @server.feature(
        types.TEXT_DOCUMENT_SEMANTIC_TOKENS_FULL,
        types.SemanticTokensLegend(token_types=list(TOKEN_TYPES), token_modifiers=["declaration"]),
    )
    def tokens(ls: RmvServer, params: types.SemanticTokensParams) -> types.SemanticTokens:
        result = ls.checked(params.text_document.uri)
        if result is None:
            return types.SemanticTokens(data=[])
        path = ls.document(params.text_document.uri).path
        found = semantic_tokens(result, path, ls.mentions_of(result))
        source = result.model.sources.get(path)
        assert source is not None  # checked() says the check read this text
        return types.SemanticTokens(data=convert.token_data(source, found, ls.encoding))

    @server.feature(types.TEXT_DOCUMENT_FOLDING_RANGE)
    def folding(ls: RmvServer, params: types.FoldingRangeParams) -> list[types.FoldingRange]:
        document = ls.document(params.text_document.uri)
        result = ls.state.results.get(document.path)
        if result is None:
            return []
        return [
            types.FoldingRange(start_line=first, end_line=last)
            for first, last in folds(result.model, document.path)
        ]

    @server.feature(types.WORKSPACE_SYMBOL)
    def workspace_symbols(
        ls: RmvServer, params: types.WorkspaceSymbolParams
    ) -> list[types.SymbolInformation]:
        """Every declared name of the checked documents (and what they import)
        that contains the query, ignoring case."""
        query, seen, out = params.query.lower(), set(), []
        for result in list(ls.state.results.values()):
            for symbol in result.model.symbols.values():
                key = (symbol.name, symbol.span.path, symbol.span.start)
                if query in symbol.name.lower() and key not in seen:
                    location = ls.location(result.model, symbol.span)
                    if location is not None:
                        seen.add(key)
                        kind = SYMBOL_KINDS[symbol.kind]
                        out.append(
                            types.SymbolInformation(location=location, name=symbol.name, kind=kind)
                        )
        return out

    @server.feature(types.TEXT_DOCUMENT_FORMATTING)
    def formatting(ls: RmvServer, params: types.DocumentFormattingParams) -> list[types.TextEdit]:
        document = ls.document(params.text_document.uri)
        text = formatted(document.path, document.source)
        if text is None or text == document.source:
            return []
        end = types.Position(line=len(document.lines), character=0)
        whole = types.Range(start=types.Position(line=0, character=0), end=end)
        return [types.TextEdit(range=whole, new_text=text)]

    return server


def hover_text(model: Model, symbol: Symbol, known: list[str]) -> str:
    """What a hover shows: the kind and name, the declaration's first line, what
    the check knows of it (`known`), the state's transducer, and the doc comment."""
    lines = [f"**{symbol.kind.value}** `{symbol.name}`"]
    if symbol.owner:
        lines[0] += f" of transducer `{symbol.owner}`"
    source = model.sources.get(symbol.span.path)
    if source is not None:
        declared = source.line_text(source.position(symbol.span.start).line).strip()
        lines.append(f"```rmv\n{declared}\n```")
    lines.extend(known)
    doc = str(getattr(symbol.decl, "doc", "") or "")
    if doc:
        lines.append(doc)
    return "\n\n".join(lines)


def outline(model: Model, path: str, encoding: str) -> list[types.DocumentSymbol]:
    """The file's declarations, with each transducer's states inside it."""
    source = model.sources.get(path)
    if source is None:
        return []
    mine = [s for s in model.symbols.values() if s.span.path == path]

    def entry(symbol: Symbol, children: list[types.DocumentSymbol]) -> types.DocumentSymbol:
        where = convert.lsp_range(source, symbol.span, encoding)
        decl_span = getattr(symbol.decl, "span", None)
        whole = where if decl_span is None else convert.lsp_range(source, decl_span, encoding)
        if not (whole.start.line <= where.start.line and whole.end.line >= where.end.line):
            whole = where
        return types.DocumentSymbol(
            name=symbol.name, kind=SYMBOL_KINDS[symbol.kind], range=whole,
            selection_range=where, detail=symbol.kind.value, children=children or None,
        )  # fmt: skip

    states: dict[str, list[types.DocumentSymbol]] = {}
    for symbol in mine:
        if symbol.kind is Kind.STATE and symbol.owner:
            states.setdefault(symbol.owner, []).append(entry(symbol, []))
    return [
        entry(s, states.get(s.name, []) if s.kind is Kind.TRANSDUCER else [])
        for s in sorted(mine, key=lambda s: s.span.start)
        if s.kind is not Kind.STATE
    ]


def main() -> None:
    build().start_io()
