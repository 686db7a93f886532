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


def lsp_range(source: SourceFile, span: Span, encoding: str) -> types.Range:
    """A span as an LSP range, in the encoding the client negotiated, counted on
    the text that was checked (open in the editor or not)."""
    return types.Range(
        start=_position(source, span.start, encoding), end=_position(source, span.end, encoding)
    )


def _position(source: SourceFile, offset: int, encoding: str) -> types.Position:
    where = source.position(offset)
    before = source.line_text(where.line)[: where.column - 1]
    return types.Position(line=where.line - 1, character=code_units(before, encoding))


def code_units(text: str, encoding: str) -> int:
    """The length of a text in the encoding's code units (UTF-32: code points)."""
    if encoding == types.PositionEncodingKind.Utf8:
        return len(text.encode("utf-8", "surrogatepass"))
    if encoding == types.PositionEncodingKind.Utf16:
        return len(text.encode("utf-16-le", "surrogatepass")) // 2
    return len(text)


def offset_at(document: TextDocument, position: types.Position) -> int:
    """The code-point offset of an LSP position in the document's text (its lines
    keep their line ends)."""
    where = document.position_codec.position_from_client_units(document.lines, position)
    return sum(len(line) for line in document.lines[: where.line]) + where.character


def diagnostic(found: Diagnostic, sources: SourceMap, encoding: str) -> types.Diagnostic | None:
    """One of `rmv check`'s diagnostics, with its secondary labels as related
    information and its code linked to its explanation."""
    source = sources.get(found.span.path)
    if source is None:
        return None
    related = []
    for label in found.secondary:
        other = sources.get(label.span.path)
        if other is not None:
            where = lsp_range(other, label.span, encoding)
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
        range=lsp_range(source, found.span, encoding),
        message=message,
        severity=SEVERITY[found.severity],
        code=found.code,
        code_description=description,
        source="rmv",
        related_information=related or None,
    )


def uri_of(path: str) -> str:
    return Path(path).resolve().as_uri()
