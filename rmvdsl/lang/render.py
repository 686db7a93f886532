"""Showing diagnostics: rustc-style text, JSON and SARIF 2.1.0.

Lines and columns are 1-based and count characters; `end_column` is the column
just after the span (exclusive), as in SARIF.
"""

from __future__ import annotations

import json
import os
import unicodedata
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from rmvdsl import __version__
from rmvdsl.lang.codes import CODES
from rmvdsl.lang.diagnostics import Diagnostic, Fix, Severity, fixes_of
from rmvdsl.lang.source import SourceMap, Span
from rmvdsl.runtime.wording import counted, visible


@dataclass(frozen=True)
class Region:
    file: str
    line: int
    column: int
    end_line: int
    end_column: int


def region(span: Span, sources: SourceMap) -> Region:
    source = sources.get(span.path)
    if source is None:
        return Region(span.path, 1, 1, 1, 1)
    start = source.position(span.start)
    end = source.position(span.end)
    return Region(span.path, start.line, start.column, end.line, end.column)


class _Style:
    def __init__(self, color: bool) -> None:
        self.color = color

    def paint(self, text: str, *codes: str) -> str:
        if not self.color or not text:
            return text
        return f"\033[{';'.join(codes)}m{text}\033[0m"


_SEVERITY_COLORS = {Severity.ERROR: "31", Severity.WARNING: "33", Severity.NOTE: "36"}


def width(text: str) -> int:
    """Columns a terminal gives the text: wide (CJK, most emoji) characters take two,
    combining marks none."""
    total = 0
    for char in text:
        if unicodedata.combining(char):
            continue
        total += 2 if unicodedata.east_asian_width(char) in "WF" else 1
    return total


SHOWN_PER_FILE = 100  # diagnostics drawn per file; the rest are counted


def render_text(diagnostics: Iterable[Diagnostic], sources: SourceMap, color: bool = False) -> str:
    """The diagnostics drawn, at most SHOWN_PER_FILE of each file, then how many more
    each file has (a file of junk gives a page, not megabytes)."""
    style = _Style(color)
    shown: dict[str, int] = {}
    more: dict[str, int] = {}
    out = []
    for diagnostic in diagnostics:
        path = diagnostic.span.path
        if shown.get(path, 0) >= SHOWN_PER_FILE:
            more[path] = more.get(path, 0) + 1
            continue
        shown[path] = shown.get(path, 0) + 1
        out.append(_render_one(diagnostic, sources, style) + "\n")
    for path, count in more.items():
        out.append(f"{visible(path)}: {counted(count, 'more diagnostic', grouped=True)} not shown "
                   "(`--format json` lists every one)\n")  # fmt: skip
    return "".join(out)


def _render_one(diagnostic: Diagnostic, sources: SourceMap, style: _Style) -> str:
    severity_color = _SEVERITY_COLORS[diagnostic.severity]
    head = style.paint(f"{diagnostic.severity.value}[{diagnostic.code}]", "1", severity_color)
    lines = [f"{head}{style.paint(': ' + visible(diagnostic.message), '1')}"]
    primary = region(diagnostic.span, sources)
    labels = [(diagnostic.span, diagnostic.label, True)]
    labels += [(label.span, label.message, False) for label in diagnostic.secondary]
    digits = len(str(max(region(span, sources).line for span, _, _ in labels)))
    gutter = style.paint(" " * digits + " |", "1", "34")
    arrow = style.paint(" " * digits + "-->", "1", "34")
    lines.append(f"{arrow} {visible(primary.file)}:{primary.line}:{primary.column}")
    shown_files = {diagnostic.span.path}
    by_line: dict[tuple[str, int], list[tuple[Span, str, bool]]] = {}
    for label in labels:
        by_line.setdefault((label[0].path, region(label[0], sources).line), []).append(label)
    ordered = sorted(by_line, key=lambda key: (key[0] != diagnostic.span.path, key[0], key[1]))
    for path, line in ordered:
        if path not in shown_files:
            where = region(by_line[(path, line)][0][0], sources)
            lines.append(
                style.paint(" " * digits + ":::", "1", "34")
                + f" {visible(where.file)}:{where.line}:{where.column}"
            )
            shown_files.add(path)
        lines.extend(_snippet(by_line[(path, line)], sources, style, digits, severity_color))
    lines.append(gutter)
    if diagnostic.help:
        help = visible(diagnostic.help)
        lines.append(f"{' ' * digits} {style.paint('= help:', '1', '36')} {help}")
    if diagnostic.notes:
        head, *rest = (visible(note) for note in diagnostic.notes)
        lines.append(f"{' ' * digits} {style.paint('= note:', '1')} {head}")
        lines.extend(f"{' ' * (digits + 9)}{line}" for line in rest)
    return "\n".join(lines)


def _snippet(
    labels: list[tuple[Span, str, bool]],
    sources: SourceMap,
    style: _Style,
    digits: int,
    severity_color: str,
) -> list[str]:
    """One source line and an underline for each label on it."""
    gutter = style.paint(" " * digits + " |", "1", "34")
    source = sources.get(labels[0][0].path)
    if source is None:
        return [gutter]
    first = region(labels[0][0], sources)
    raw = source.line_text(first.line)
    spans = [_columns(region(span, sources), raw) for span, _, _ in labels]
    low, high, cut = _shown(raw, spans)
    text = ("…" if low else "") + visible(raw[low:high].expandtabs(1)) + ("…" if cut else "")
    number = style.paint(str(first.line).rjust(digits) + " |", "1", "34")
    out = [gutter, f"{number} {text}"]
    ordered = sorted(zip(labels, spans, strict=True), key=lambda pair: pair[0][0].start)
    for (_, message, is_primary), (start, end) in ordered:
        start, end = min(max(start, low), high), min(max(end, low), high)
        # columns count characters; a terminal counts cells (a wide character is two)
        before = width(visible(raw[low:start].expandtabs(1))) + (1 if low else 0)
        under = width(visible(raw[start:end].expandtabs(1)))
        mark = ("^" if is_primary else "-") * max(1, under)
        color = severity_color if is_primary else "34"
        label = f"{mark} {visible(message)}".rstrip()
        out.append(f"{gutter} {' ' * before}{style.paint(label, '1', color)}")
    return out


LONG_LINE = 200  # characters of a line shown whole; a longer one is cut around its marks
_SHOWN = 160  # at most this many of a long line's characters
_CONTEXT = 50


def _columns(where: Region, raw: str) -> tuple[int, int]:
    """A label's characters on its first line, as offsets into the line."""
    end = where.end_column if where.end_line == where.line else len(raw) + 1
    return where.column - 1, end - 1


def _shown(raw: str, spans: list[tuple[int, int]]) -> tuple[int, int, bool]:
    """The part of a line to show: all of it when short; else from some characters
    before the first mark to some after the last (at most a screen's worth)."""
    if len(raw) <= LONG_LINE:
        return 0, len(raw), False
    low = max(0, min(start for start, _ in spans) - _CONTEXT)
    high = min(len(raw), max(end for _, end in spans) + _CONTEXT, low + _SHOWN)
    return low, high, high < len(raw)


def summary(paths: list[str], diagnostics: list[Diagnostic]) -> str:
    errors = sum(d.severity is Severity.ERROR for d in diagnostics)
    warnings = sum(d.severity is Severity.WARNING for d in diagnostics)
    files = visible(paths[0]) if len(paths) == 1 else counted(len(paths), "file")
    return f"{files}: {counted(errors, 'error')}, {counted(warnings, 'warning')}"


def as_json_objects(diagnostics: Iterable[Diagnostic], sources: SourceMap) -> list[dict[str, Any]]:
    objects = []
    for diagnostic in diagnostics:
        where = region(diagnostic.span, sources)
        labels = [_label_json(diagnostic.span, diagnostic.label, True, sources)]
        labels += [
            _label_json(label.span, label.message, False, sources) for label in diagnostic.secondary
        ]
        objects.append(
            {
                "severity": diagnostic.severity.value,
                "code": diagnostic.code,
                "message": diagnostic.message,
                "file": where.file,
                "line": where.line,
                "column": where.column,
                "end_line": where.end_line,
                "end_column": where.end_column,
                "labels": labels,
                "help": diagnostic.help,
                "fixes": [_fix_json(fix, sources) for fix in fixes_of(diagnostic)],
            }
        )
    return objects


def _fix_json(fix: Fix, sources: SourceMap) -> dict[str, Any]:
    """A fix as a replacement of [line:column, end_line:end_column) by `text`."""
    where = _label_json(fix.span, fix.title, False, sources)
    where.pop("primary")
    return {"title": where.pop("message"), **where, "text": fix.text}


def _label_json(span: Span, message: str, primary: bool, sources: SourceMap) -> dict[str, Any]:
    where = region(span, sources)
    return {
        "message": message,
        "primary": primary,
        "file": where.file,
        "line": where.line,
        "column": where.column,
        "end_line": where.end_line,
        "end_column": where.end_column,
    }


def render_json(diagnostics: Iterable[Diagnostic], sources: SourceMap) -> str:
    return json.dumps(as_json_objects(diagnostics, sources), indent=2) + "\n"


_SARIF_LEVELS = {Severity.ERROR: "error", Severity.WARNING: "warning", Severity.NOTE: "note"}


def render_sarif(diagnostics: list[Diagnostic], sources: SourceMap) -> str:
    used = sorted({d.code for d in diagnostics})
    rules = [
        {
            "id": code,
            "name": CODES[code].title.title().replace(" ", ""),
            "shortDescription": {"text": CODES[code].title},
            "fullDescription": {"text": CODES[code].explanation},
            "help": {"text": CODES[code].explanation},
        }
        for code in used
    ]
    results = []
    for diagnostic in diagnostics:
        text = diagnostic.message + (f"\nhelp: {diagnostic.help}" if diagnostic.help else "")
        results.append(
            {
                "ruleId": diagnostic.code,
                "ruleIndex": used.index(diagnostic.code),
                "level": _SARIF_LEVELS[diagnostic.severity],
                "message": {"text": text},
                "locations": [_sarif_location(diagnostic.span, diagnostic.label, sources)],
                "relatedLocations": [
                    {"id": index, **_sarif_location(label.span, label.message, sources)}
                    for index, label in enumerate(diagnostic.secondary)
                ],
            }
        )
    document = {
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [
            {
                "tool": {
                    "driver": {
                        "name": "rmv",
                        "version": __version__,
                        "rules": rules,
                    }
                },
                "columnKind": "unicodeCodePoints",
                "results": results,
            }
        ],
    }
    return json.dumps(document, indent=2) + "\n"


def _sarif_location(span: Span, message: str, sources: SourceMap) -> dict[str, Any]:
    where = region(span, sources)
    location: dict[str, Any] = {
        "physicalLocation": {
            "artifactLocation": {"uri": _uri(where.file)},
            "region": {
                "startLine": where.line,
                "startColumn": where.column,
                "endLine": where.end_line,
                "endColumn": max(where.end_column, where.column),
            },
        }
    }
    if message:
        location["message"] = {"text": message}
    return location


def _uri(path: str) -> str:
    relative = os.path.relpath(path) if os.path.isabs(path) else path
    return relative.replace(os.sep, "/")
