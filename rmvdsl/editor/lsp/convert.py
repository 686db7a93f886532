"""Between rmvdsl's values (spans of code-point offsets, diagnostics) and the
Language Server Protocol's (positions in the code units the client negotiated:
UTF-16 unless it asked for another)."""

from __future__ import annotations

import functools
import os
from pathlib import Path

from lsprotocol import types
from pygls.workspace import PositionCodec, TextDocument

from rmvdsl.editor.workspace import TOKEN_TYPES, Token
from rmvdsl.lang.codes import diagnostics_markdown
from rmvdsl.lang.diagnostics import Diagnostic, Severity, fixes_of
from rmvdsl.lang.source import SourceFile, SourceMap, Span
from rmvdsl.util.cache import digest
from rmvdsl.util.folders import cache_folder

SEVERITY = {
    Severity.ERROR: types.DiagnosticSeverity.Error,
    Severity.WARNING: types.DiagnosticSeverity.Warning,
    Severity.NOTE: types.DiagnosticSeverity.Information,  # a solver stage's finding
}


@functools.cache
def explanations() -> Path | None:
    """A file holding docs/diagnostics.md, each code's explanation, for the codes'
    links: rendered from the code registry (the docs page is the same text) into
    the cache folder, since an installed package has no docs/ beside it. None when
    there is no folder to write to."""
    folder = cache_folder()
    if folder is None:
        return None
    text = diagnostics_markdown()
    path = Path(folder) / f"diagnostics-{digest(text)[:12]}.md"
    try:
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            temporary = path.with_name(f".{path.name}.{os.getpid()}")
            temporary.write_text(text, encoding="utf-8")
            os.replace(temporary, path)
    except OSError:
        return None
    return path


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


# What str.splitlines, and so pygls's `lines`, breaks a line at besides "\n".
_OTHER_BREAKS = "\r\v\f\x1c\x1d\x1e"
_OTHER_BREAKS_BEYOND_ASCII = "\x85\u2028\u2029"


def offset_at(document: TextDocument, position: types.Position) -> int:
    """The code-point offset of an LSP position in the document's text, its lines
    as pygls's `lines` splits them (with their line ends). `lines` splits the
    whole text, twice here, each time it is read: at 20,805 lines, 5 ms of each
    completion. A text whose lines end in "\n" alone (checked in C, in
    microseconds) has only its lines up to the position's split."""
    line = quick_line(document.source, position.line)
    if line is not None:
        return offset_in(document.position_codec, line, position)
    # another line end, or a position past the last line: pygls's rule as it is
    lines = document.lines
    where = document.position_codec.position_from_client_units(lines, position)
    return sum(map(len, lines[: where.line])) + where.character


def quick_line(text: str, number: int) -> tuple[int, str] | None:
    """Where line `number` (0-based) starts, and its text with its line end, when
    every line of `text` ends in "\n" and it has that line; None otherwise."""
    if not _newlines_alone(text):
        return None
    head = text.split("\n", number)
    if len(head) <= number or not head[-1]:
        return None  # past the last line
    start = len(text) - len(head[-1])
    end = text.find("\n", start)
    return start, text[start : len(text) if end < 0 else end + 1]


def offset_in(codec: PositionCodec, line: tuple[int, str], position: types.Position) -> int:
    """The offset of `position`, on the line `quick_line` found."""
    start, text = line
    where = codec.position_from_client_units([text], types.Position(0, position.character))
    return start + where.character


def _newlines_alone(text: str) -> bool:
    """Whether "\n" is the only line end str.splitlines finds in `text`."""
    if any(other in text for other in _OTHER_BREAKS):
        return False
    return text.isascii() or not any(other in text for other in _OTHER_BREAKS_BEYOND_ASCII)


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
    page = explanations()
    if page is not None:
        description = types.CodeDescription(href=f"{page.as_uri()}#{found.code.lower()}")
    fixes = [
        {"title": fix.title, "uri": uri_of(fix.span.path),
         "range": _json_range(lsp_range(fix_source, fix.span, encoding)), "newText": fix.text}
        for fix in fixes_of(found)
        if (fix_source := sources.get(fix.span.path)) is not None
    ]  # fmt: skip
    return types.Diagnostic(
        range=lsp_range(source, found.span, encoding),
        message=message,
        severity=SEVERITY[found.severity],
        code=found.code,
        code_description=description,
        source="rmv",
        related_information=related or None,
        data={"fixes": fixes} if fixes else None,
    )


def _json_range(where: types.Range) -> dict[str, dict[str, int]]:
    # `data` travels as plain JSON and comes back in a code action request.
    return {
        "start": {"line": where.start.line, "character": where.start.character},
        "end": {"line": where.end.line, "character": where.end.character},
    }


def edits_of(found: types.Diagnostic) -> list[tuple[str, str, types.TextEdit]]:
    """The fixes a published diagnostic carries: (title, uri, edit) each."""
    data = found.data if isinstance(found.data, dict) else {}
    out = []
    for fix in data.get("fixes", ()):
        try:
            start, end = fix["range"]["start"], fix["range"]["end"]
            where = types.Range(
                types.Position(start["line"], start["character"]),
                types.Position(end["line"], end["character"]),
            )
            out.append((str(fix["title"]), str(fix["uri"]), types.TextEdit(where, fix["newText"])))
        except (KeyError, TypeError):
            continue  # not ours, or changed by the client: no fix offered
    return out


def uri_of(path: str) -> str:
    return Path(path).resolve().as_uri()


def token_data(source: SourceFile, tokens: list[Token], encoding: str) -> list[int]:
    """Semantic tokens as LSP encodes them: five integers each (line and start as
    deltas from the previous token, length, type, modifiers), one line each."""
    data: list[int] = []
    line = character = 0
    for token in tokens:
        where = lsp_range(source, token.span, encoding)
        if where.start.line != where.end.line:
            continue
        start = where.start
        delta_line = start.line - line
        delta_start = start.character - character if delta_line == 0 else start.character
        kind = TOKEN_TYPES.index(token.type)
        length = where.end.character - start.character
        data += [delta_line, delta_start, length, kind, 1 if token.declaration else 0]
        line, character = start.line, start.character
    return data
