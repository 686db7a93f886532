"""Between rmvdsl's values (spans of code-point offsets, diagnostics) and the
Language Server Protocol's (positions in the code units the client negotiated:
UTF-16 unless it asked for another)."""

from __future__ import annotations

from pathlib import Path

from lsprotocol import types
from pygls.workspace import TextDocument

from rmvdsl.diagnostics import Diagnostic, Severity
from rmvdsl.source import SourceFile, SourceMap, Span

SEVERITY = {
    Severity.ERROR: types.DiagnosticSeverity.Error,
    Severity.WARNING: types.DiagnosticSeverity.Warning,
}
# docs/diagnostics.md beside the package (a source checkout): each code's explanation.
_EXPLANATIONS = Path(__file__).resolve().parents[2] / "docs" / "diagnostics.md"


def lsp_range(source: SourceFile, span: Span, document: TextDocument | None) -> types.Range:
    """A span as an LSP range, in the document's position encoding."""
    return types.Range(
        start=_position(source, span.start, document), end=_position(source, span.end, document)
    )


def _position(source: SourceFile, offset: int, document: TextDocument | None) -> types.Position:
    where = source.position(offset)
    position = types.Position(line=where.line - 1, character=where.column - 1)
    if document is None:
        return position
    return document.position_codec.position_to_client_units(document.lines, position)


def offset_at(source: SourceFile, document: TextDocument, position: types.Position) -> int:
    """The code-point offset of an LSP position in the document."""
    where = document.position_codec.position_from_client_units(document.lines, position)
    return source.offset(where.line + 1, where.character + 1)


def document_offset(document: TextDocument, position: types.Position) -> int:
    """The code-point offset of an LSP position in the document's own text (its
    lines keep their line ends)."""
    where = document.position_codec.position_from_client_units(document.lines, position)
    return sum(len(line) for line in document.lines[: where.line]) + where.character


def diagnostic(
    found: Diagnostic, sources: SourceMap, documents: dict[str, TextDocument]
) -> types.Diagnostic | None:
    """One of `rmv check`'s diagnostics, with its secondary labels as related
    information and its code linked to its explanation; `documents` are the open
    ones by path (their positions follow the client's encoding)."""
    source = sources.get(found.span.path)
    if source is None:
        return None
    related = []
    for label in found.secondary:
        other = sources.get(label.span.path)
        if other is not None:
            where = lsp_range(other, label.span, documents.get(label.span.path))
            location = types.Location(uri=uri_of(label.span.path), range=where)
            related.append(types.DiagnosticRelatedInformation(location, label.message))
    message = found.message
    if found.label:
        message += f" ({found.label})"
    if found.help:
        message += f"\nhelp: {found.help}"
    for note in found.notes:
        message += f"\n{note}"
    description = None
    if _EXPLANATIONS.exists():
        description = types.CodeDescription(href=f"{_EXPLANATIONS.as_uri()}#{found.code.lower()}")
    return types.Diagnostic(
        range=lsp_range(source, found.span, documents.get(found.span.path)),
        message=message,
        severity=SEVERITY[found.severity],
        code=found.code,
        code_description=description,
        source="rmv",
        related_information=related or None,
    )


def uri_of(path: str) -> str:
    return Path(path).resolve().as_uri()
