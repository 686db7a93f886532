"""Parsing .rmv text into the AST, recovering from errors.

Recovery works on two levels. The scanner cuts the file into top-level
declarations and each is parsed on its own, so one broken declaration never hides
the next. Inside a declaration, the LALR parser is driven token by token: a
missing `)`, `]` or `}` is inserted when that lets the parse go on, otherwise the
offending token is skipped; a new error is reported only after three tokens were
accepted since the previous one, so one mistake gives one message.
"""

from __future__ import annotations

import dataclasses
import itertools
import re
from dataclasses import dataclass, field
from typing import Any, cast

from lark.exceptions import UnexpectedInput, UnexpectedToken

from rmvdsl.grammar import ast
from rmvdsl.grammar.builder import AstBuilder
from rmvdsl.grammar.formula import Formula
from rmvdsl.grammar.grammars import (
    describe_expected,
    latex_parser,
    spec_parser,
)
from rmvdsl.grammar.recovery import ChunkParser
from rmvdsl.grammar.scanner import RawComment, ScanResult, chunk_before, scan
from rmvdsl.grammar.shift import keep_findings, shifted, with_field
from rmvdsl.lang.diagnostics import Diagnostic, did_you_mean, error
from rmvdsl.lang.source import SourceFile, Span
from rmvdsl.util.bounded import Bounded

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@dataclass
class ParsedSpec:
    spec: ast.Spec
    diagnostics: list[Diagnostic]
    # Identifiers of declarations that had syntax errors: names that may have been
    # lost, so that "undefined name" is not reported for them.
    damaged_names: set[str] = field(default_factory=set)
    # Offsets [start, end) of the declarations that had syntax errors.
    damaged_ranges: list[tuple[int, int]] = field(default_factory=list)


@dataclass(frozen=True)
class _Chunk:
    """One declaration chunk's parse, as parsed at `start`."""

    start: int
    decls: tuple[ast.Decl, ...] | None
    diagnostics: tuple[Diagnostic, ...]  # the chunk's own and the builder's
    damaged: bool


# An editor re-parses a file at every keystroke; most of its declarations have not
# changed. Chunks are kept by their file and text (a bounded cache) and reused with
# their spans moved to where the chunk now starts. The bound grows to twice the
# chunks of the largest file parsed: a file larger than the cache would otherwise
# evict its own chunks on every parse (a 159,000-line spec was parsed from scratch
# each time, 1.5 times lark's bare parse).
_CHUNK_CACHE_SIZE = 50_000
_CHUNK_CACHE: Bounded[tuple[str, str], _Chunk] = Bounded(_CHUNK_CACHE_SIZE)


def _parse_chunk(
    source: SourceFile, start: int, end: int, line: int, builder: AstBuilder
) -> _Chunk:
    """A chunk not in the cache: parsed, and kept by its file and text."""
    before = len(builder.diagnostics)
    parser = ChunkParser(source, start, end, line)
    decls = parser.parse()
    damaged = bool(parser.diagnostics) or decls is None
    latex: list[Diagnostic] = []
    if decls is not None:
        decls, latex = _parse_latex_bodies(decls)
    found = (*parser.diagnostics, *builder.diagnostics[before:], *latex)
    kept = None if decls is None else tuple(decls)
    if kept is not None and not damaged:  # a partial tree is checked each time
        keep_findings(kept)
    chunk = _Chunk(start, kept, found, damaged)
    _CHUNK_CACHE.put((source.path, source.text[start:end]), chunk)
    return chunk


# The last text parsed of each file (the most recent files) and its scan: the next
# parse of the file scans only what an edit changed.
_LAST_SCANS: Bounded[str, tuple[str, ScanResult]] = Bounded(64)
# The last few texts scanned, by file and text: an editor's check of a keystroke
# reads the scan of the text its last check read (rmvdsl.check.edit), and
# completion and the checks of newer keys scanned other texts since. (A text's
# hash is worked out once per string: the key costs little.)
_RECENT_SCANS: Bounded[tuple[str, str], ScanResult] = Bounded(8)


def _scanned(source: SourceFile) -> ScanResult:
    return scan_file(source.path, source.text)


def scan_file(path: str, text: str) -> ScanResult:
    """The scan of a file's text, from its last scan (the parse of an editor's
    previous keystroke, or its completion's): only what an edit changed is scanned."""
    scanned = scan(text, _LAST_SCANS.get(path))
    _LAST_SCANS.put(path, (text, scanned))
    _RECENT_SCANS.put((path, text), scanned)
    return scanned


def chunk_start(path: str, text: str, offset: int) -> int:
    """The start of the declaration chunk of a file's text that `offset` is in
    (the last one starting before it; 0 when none does), from the file's last
    scan: what an edit changed is scanned again, and nothing is kept or moved
    (completion asks at each key; the next parse scans for itself)."""
    last = _LAST_SCANS.get(path)
    if last is None:
        return chunk_before(text, text, scan_file(path, text), offset)
    return chunk_before(text, *last, offset)


def damaged_names(text: str, start: int, end: int) -> set[str]:
    """The identifiers of a chunk with a syntax error: names it may have declared,
    so that "undefined name" is not reported for them."""
    return set(_IDENTIFIER.findall(text, start, end))


def last_scan(path: str, text: str) -> ScanResult:
    """The scan of a file's text: one of the last made, if it was of this text."""
    found = _RECENT_SCANS.get((path, text))
    return found if found is not None else scan_file(path, text)


def parse_chunk(
    path: str, text: str, start: int, end: int, line: int
) -> tuple[tuple[ast.Decl, ...] | None, tuple[Diagnostic, ...], bool]:
    """One declaration chunk of a file's text (`scan_file`'s `start` on `line`, up
    to `end`) as parse_source parses it: its declarations, its diagnostics, whether
    it has syntax errors (its tree may then be partial). A chunk parsed before is
    not parsed again (nor is the file's line table made)."""
    chunk = _CHUNK_CACHE.get((path, text[start:end]))
    if chunk is None:
        _, builder = spec_parser()
        builder.start_parse(path)
        chunk = _parse_chunk(SourceFile(path, text), start, end, line, builder)
    delta = start - chunk.start
    decls, found = chunk.decls, tuple(_unique(list(chunk.diagnostics)))  # as parse_source
    if delta:
        decls = None if decls is None else shifted(decls, delta)
        found = shifted(found, delta)
    return decls, found, chunk.damaged


def parse_source(source: SourceFile) -> ParsedSpec:
    """Parse a whole file: every declaration, every syntax error."""
    _, builder = spec_parser()
    builder.start_parse(source.path)
    scanned = _scanned(source)
    items: list[ast.Decl] = []
    diagnostics: list[Diagnostic] = []
    damaged: set[str] = set()
    ranges: list[tuple[int, int]] = []
    bounds = [*scanned.chunks, (len(source.text), 0)]
    _CHUNK_CACHE.fit(len(bounds))
    # Each chunk's parse, kept or made, and how far it moved since: most are kept,
    # looked up here through the cache's own dict (without a call each).
    text, path, kept = source.text, source.path, _CHUNK_CACHE.reader()
    for (start, line), (end, _) in itertools.pairwise(bounds):
        chunk = kept((path, text[start:end])) or _parse_chunk(source, start, end, line, builder)
        delta = start - chunk.start
        if chunk.decls:
            items.extend(shifted(chunk.decls, delta) if delta else chunk.decls)
        if chunk.diagnostics:
            diagnostics.extend(shifted(chunk.diagnostics, delta) if delta else chunk.diagnostics)
        if chunk.damaged:
            damaged.update(damaged_names(source.text, start, end))
            ranges.append((start, end))
    items = _attach_docs(items, scanned.comments, source)
    comments = tuple(ast.Comment(c.text, source.span(c.start, c.end)) for c in scanned.comments)
    spec = ast.Spec(source.path, tuple(items), comments, source.span(0, len(source.text)))
    return ParsedSpec(spec, _unique(diagnostics), damaged, ranges)


def _unique(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    return list(dict.fromkeys(diagnostics))


def _attach_docs(
    items: list[ast.Decl], comments: tuple[RawComment, ...], source: SourceFile
) -> list[ast.Decl]:
    doc_lines: dict[int, str] = {}
    for comment in comments:
        if comment.own_line and comment.text.startswith("///"):
            text = comment.text[3:]
            doc_lines[source.position(comment.start).line] = text[1:] if text[:1] == " " else text
    if not doc_lines:
        return items
    attached = []
    for item in items:
        line = source.position(item.span.start).line - 1
        lines = []
        while line in doc_lines:
            lines.append(doc_lines[line])
            line -= 1
        doc = "\n".join(reversed(lines))
        attached.append(with_field(item, "doc", doc) if doc else item)
    return attached


def _parse_latex_bodies(items: list[ast.Decl]) -> tuple[list[ast.Decl], list[Diagnostic]]:
    diagnostics: list[Diagnostic] = []
    result: list[ast.Decl] = []
    for item in items:
        if isinstance(item, ast.PropertyDecl) and isinstance(item.body, ast.LatexFormula):
            formula, found = parse_latex(item.body.source)
            diagnostics.extend(found)
            body = dataclasses.replace(item.body, formula=formula)
            item = dataclasses.replace(item, body=body)
        result.append(item)
    return result, diagnostics


def parse_latex(literal: ast.StringLit, start: str = "start") -> tuple[Any, list[Diagnostic]]:
    """Parse the LaTeX notation inside a string literal; spans point into the file."""
    parser, builder = latex_parser()
    path = literal.span.path
    offsets = literal.offsets or tuple(range(literal.span.start + 1, literal.span.end - 1))
    value = literal.value

    def file_span(start: int, end: int) -> Span:
        if not offsets:
            return literal.span
        first = (
            offsets[min(start, len(offsets) - 1)] if start < len(offsets) else literal.span.end - 1
        )
        last = offsets[end - 1] + 1 if 0 < end <= len(offsets) else first
        return Span(path, first, max(first, last))

    builder.start_parse(path, lambda token: file_span(token.start_pos or 0, token.end_pos or 0))
    try:
        formula = parser.parse(value, start=start)
    except UnexpectedInput as exc:
        return None, [*builder.diagnostics, _latex_error(exc, value, file_span)]
    return cast(Formula, formula), list(builder.diagnostics)


def _latex_error(exc: UnexpectedInput, value: str, file_span: Any) -> Diagnostic:
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        start = token.start_pos if token.type != "$END" else len(value)
        end = token.end_pos if token.type != "$END" else len(value)
        found = "the end of the formula" if token.type == "$END" else f"`{token}`"
        message = f"expected {describe_expected(set(exc.expected), 'latex')}, found {found}"
    else:
        start = exc.pos_in_stream or 0
        end = start + 1
        command = re.match(r"\\[A-Za-z]+", value[start:])
        found = command.group(0) if command else value[start : start + 1]
        message = f"unknown command or character `{found}`"
        end = start + len(found)
        suggestion = did_you_mean(found, LATEX_COMMANDS) if command else None
        if suggestion:
            return error(
                "RMV104",
                f"in LaTeX formula: {message}",
                file_span(start, end),
                label="not a command of the notation",
                help=suggestion,
            )
    return error(
        "RMV104",
        f"in LaTeX formula: {message}",
        file_span(start or 0, end or 0),
        label="here",
        help="the notation is rmtld3synth's: see `rmv explain RMV104`",
    )


LATEX_COMMANDS = (
    "\\lor",
    "\\vee",
    "\\land",
    "\\wedge",
    "\\neg",
    "\\lnot",
    "\\not",
    "\\rightarrow",
    "\\implies",
    "\\leftrightarrow",
    "\\iff",
    "\\until",
    "\\since",
    "\\eventually",
    "\\always",
    "\\int",
    "\\top",
    "\\bot",
    "\\leq",
    "\\geq",
    "\\left",
    "\\right",
)
