"""The language server's features over a checked document: hover, definition,
references, symbols, completion, rename, code actions, semantic tokens, folding
and formatting, each through rmvdsl.editor.workspace (completion through
rmvdsl.editor.completion)."""

from __future__ import annotations

from lsprotocol import types
from pygls.exceptions import JsonRpcInvalidParams

from rmvdsl.check.model import Kind, Model, Symbol
from rmvdsl.editor.completion import sent_completions
from rmvdsl.editor.lsp import convert
from rmvdsl.editor.lsp.session import RmvServer
from rmvdsl.editor.mentions import describe, same
from rmvdsl.editor.workspace import (
    TOKEN_TYPES,
    details,
    folds,
    formatted,
    references,
    rename,
    semantic_tokens,
)

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


def register(server: RmvServer) -> None:
    """Every feature but the documents' own (server.build registers those)."""

    @server.feature(types.TEXT_DOCUMENT_HOVER)
    async def hover(ls: RmvServer, params: types.HoverParams) -> types.Hover | None:
        target = await ls.target_at(params.text_document.uri, params.position)
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
    async def definition(ls: RmvServer, params: types.DefinitionParams) -> types.Location | None:
        target = await ls.target_at(params.text_document.uri, params.position)
        if target is None:
            return None
        model = target.result.model
        if target.symbol is not None:
            return ls.location(model, target.symbol.span)
        where = target.mention.target if target.mention is not None else None
        return None if where is None else ls.location(model, where)

    @server.feature(types.TEXT_DOCUMENT_REFERENCES)
    async def find_references(ls: RmvServer, params: types.ReferenceParams) -> list[types.Location]:
        target = await ls.target_at(params.text_document.uri, params.position)
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
    async def document_symbols(
        ls: RmvServer, params: types.DocumentSymbolParams
    ) -> list[types.DocumentSymbol]:
        document = ls.document(params.text_document.uri)
        result = await ls.latest(params.text_document.uri)
        if result is None:
            return []
        return outline(result.model, document.path, ls.encoding)

    @server.feature(
        types.TEXT_DOCUMENT_COMPLETION, types.CompletionOptions(trigger_characters=["=", " "])
    )
    async def complete(ls: RmvServer, params: types.CompletionParams) -> types.CompletionList:
        document = ls.document(params.text_document.uri)
        # The newest check, even of a moment-old text: completion keeps pace with
        # typing. Only a document with no check yet waits for its first.
        result = ls.state.results.get(document.path) or await ls.analysed(params.text_document.uri)
        offset = convert.offset_at(document, params.position)
        sent, cut = sent_completions(result, document.source, offset, document.path)
        items = [
            types.CompletionItem(
                label=c.label,
                kind=COMPLETION_KINDS.get(c.kind),
                detail=c.detail,
                documentation=c.doc or None,
            )
            for c in sent
        ]
        return types.CompletionList(is_incomplete=cut, items=items)

    @server.feature(types.TEXT_DOCUMENT_RENAME)
    async def rename_symbol(
        ls: RmvServer, params: types.RenameParams
    ) -> types.WorkspaceEdit | None:
        found = await ls.found_at(params.text_document.uri, params.position)
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
    async def tokens(ls: RmvServer, params: types.SemanticTokensParams) -> types.SemanticTokens:
        result = await ls.analysed(params.text_document.uri)
        if result is None:
            return types.SemanticTokens(data=[])
        path = ls.document(params.text_document.uri).path
        found = semantic_tokens(result, path, ls.mentions_of(result))
        source = result.model.sources.get(path)
        assert source is not None  # checked() says the check read this text
        return types.SemanticTokens(data=convert.token_data(source, found, ls.encoding))

    @server.feature(types.TEXT_DOCUMENT_FOLDING_RANGE)
    async def folding(ls: RmvServer, params: types.FoldingRangeParams) -> list[types.FoldingRange]:
        document = ls.document(params.text_document.uri)
        result = await ls.latest(params.text_document.uri)
        if result is None:
            return []
        return [
            types.FoldingRange(start_line=first, end_line=last)
            for first, last in folds(result.model, document.path)
        ]

    @server.feature(types.WORKSPACE_SYMBOL)
    async def workspace_symbols(
        ls: RmvServer, params: types.WorkspaceSymbolParams
    ) -> list[types.SymbolInformation]:
        """Every declared name of the checked documents (and what they import)
        that contains the query, ignoring case."""
        await ls.all_analysed()
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
