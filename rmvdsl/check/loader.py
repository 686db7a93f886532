"""Reading a spec and the files it imports (stage 1 of the pipeline)."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field

from rmvdsl.grammar import ast
from rmvdsl.grammar.parser import parse_source
from rmvdsl.lang.diagnostics import Diagnostic, closest, error
from rmvdsl.lang.errors import UsageError
from rmvdsl.lang.files import read_text
from rmvdsl.lang.source import SourceFile, SourceMap

# Reads a file's text by its path (raises UsageError when it cannot).
Reader = Callable[[str], str]


@dataclass
class Loaded:
    sources: SourceMap
    specs: list[ast.Spec]
    diagnostics: list[Diagnostic]
    damaged_names: set[str] = field(default_factory=set)
    damaged_ranges: dict[str, list[tuple[int, int]]] = field(default_factory=dict)
    # Each file by what it is (its resolved path): one file imported by a relative
    # and an absolute path, or through a symbolic link, is read once.
    read: set[str] = field(default_factory=set)
    read_file: Reader = field(default=read_text, repr=False)


def load(path: str, text: str | None = None, read: Reader = read_text) -> Loaded:
    """Parse `path` (or the given text for it) and, depth first, its imports; files
    are read with `read` (an editor's reads its open documents before the disk)."""
    sources = SourceMap()
    loaded = Loaded(sources, [], [], read_file=read)
    root_text = read(path) if text is None else text
    _load_file(os.path.normpath(path), root_text, loaded, active=[])
    return loaded


def _load_file(path: str, text: str, loaded: Loaded, active: list[str]) -> None:
    real = os.path.realpath(path)
    loaded.read.add(real)
    source = loaded.sources.add(SourceFile(path, text))
    parsed = parse_source(source)
    loaded.specs.append(parsed.spec)
    loaded.diagnostics.extend(parsed.diagnostics)
    loaded.damaged_names |= parsed.damaged_names
    loaded.damaged_ranges[path] = parsed.damaged_ranges
    active.append(real)
    for item in parsed.spec.items:
        if isinstance(item, ast.ImportDecl):
            _load_import(path, item, loaded, active)
    active.pop()


def _load_import(importer: str, item: ast.ImportDecl, loaded: Loaded, active: list[str]) -> None:
    if "\0" in item.path.value:  # no file can be named so (and os.path refuses it)
        why = f"cannot import {json.dumps(item.path.value)}: a path cannot hold a NUL character"
        loaded.diagnostics.append(error("RMV003", why, item.path.span, label="not a path"))
        return
    target = os.path.normpath(os.path.join(os.path.dirname(importer), item.path.value))
    real = os.path.realpath(target)
    if real in active:
        chain = " -> ".join(os.path.basename(p) for p in [*active[active.index(real) :], real])
        loaded.diagnostics.append(
            error(
                "RMV002",
                f"import cycle: {chain}",
                item.path.span,
                label="this import closes the cycle",
                help="move the shared declarations into a file that both import",
            )
        )
        return
    if real in loaded.read:
        return  # already read through another import
    if not target.endswith(".rmv"):
        # Never read: its lines would be shown in the diagnostics of a parse.
        loaded.diagnostics.append(
            error(
                "RMV003",
                f"cannot import `{item.path.value}`: an import names a spec, a `.rmv` file",
                item.path.span,
                label="not a .rmv file",
                help='message definitions are read with `messages "folder"`',
            )
        )
        return
    try:
        text = loaded.read_file(target)
    except UsageError as exc:
        missing = not os.path.exists(target)
        loaded.diagnostics.append(
            error(
                "RMV001" if missing else "RMV003",
                f"cannot import `{item.path.value}`: {str(exc).split(': ', 1)[-1]}",
                item.path.span,
                label="imported here",
                secondary=[],
                help=_import_help(importer, item.path.value) if missing else None,
            )
        )
        return
    _load_file(target, text, loaded, active)


def _import_help(importer: str, wanted: str) -> str:
    folder = os.path.dirname(importer) or "."
    try:
        candidates = [name for name in os.listdir(folder) if name.endswith(".rmv")]
    except OSError:
        candidates = []
    best = closest(os.path.basename(wanted), candidates)
    if best:
        return f"did you mean `{best}`?"
    return f"paths are relative to the importing file's folder, {folder}"


__all__ = ["Loaded", "Reader", "load"]
