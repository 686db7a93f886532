"""The fast stages' diagnostics after an edit inside a few declarations, from the
check of the text before it: an editor's first answer to a keystroke.

An incremental check (rmvdsl.check.memo) still visits every declaration: at
20,000 lines a keystroke's fast stages took about 200 ms, 15 us a declaration.
Most keystrokes change one declaration, or a few beside each other, and leave
what the others see of them as it was (rmvdsl.check.alone.same_interface): the
names declared before and after declared alike and of the same type, names gone
read by no one else, new names new, no new read closing a cycle. Then the other
declarations' findings are as they were, but for which names are unused and
which names a syntax error quiets (both followed here), and the new diagnostics
are the old ones, each moved by the edits before it, with the edited
declarations' own (their chunks' parse, their names and their types) checked
again. A text edited in several places since the check (a few keys past it, or
several cursors) is several such edits, the text between them moved.

`check_edit` answers None whenever that cannot be shown cheaply: edits across
many chunks, imports, a declaration of another kind (a topic, a setting),
another interface, a cycle, a spec that checks nothing. The editor then waits for
the full fast stages, which it runs after this answer in any case (their model is
what hover and the solver read): tests/test_edit_check.py checks that both agree.
"""

from __future__ import annotations

import bisect
import dataclasses
import difflib
import itertools
import os
from collections import Counter
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

from rmvdsl.check.alone import (
    checked_alone,
    declared_again,
    declared_by,
    exports_as_before,
    same_interface,
    stamped_twice,
)
from rmvdsl.check.model import Model
from rmvdsl.check.names import nothing_checked
from rmvdsl.check.readers import prepare_edits, unused_changes
from rmvdsl.check.typeinfo import TypeInfo
from rmvdsl.grammar import ast
from rmvdsl.grammar.parser import damaged_names, last_scan, parse_chunk
from rmvdsl.grammar.scanner import common_prefix, common_suffix, rescan
from rmvdsl.lang.diagnostics import Diagnostic, sort_key
from rmvdsl.lang.source import SourceFile, SourceMap, Span

if TYPE_CHECKING:
    from rmvdsl.check import CheckResult

# The declarations an edit may change on its own: what they declare is a name (a
# transducer's: its states and emitted events too), and no stage reads them whole
# but their own checks (a topic's path is read by the whitelists, a setting's by
# every stage).
_LOCAL = (ast.VarDecl, ast.EventDecl, ast.AlertDecl, ast.PropertyDecl, ast.TransducerDecl)
_CYCLE = "RMV220"  # an event's type inside a cycle depends on where typing began
_MOST_CHUNKS = 8  # of the old text an edit may change (more: let the full check answer)


@dataclass(frozen=True)
class EditCheck:
    """The diagnostics of the new text, and its sources to place them by; `far`
    when the text was edited in several places since the check it was worked out
    from (each key then scans the text between them again: the editor brings the
    check up to date at once rather than after a pause in the typing)."""

    diagnostics: list[Diagnostic]
    sources: SourceMap
    far: bool = False


@dataclass(frozen=True)
class _Edit:
    """Where the old text was replaced: [start, old_end) of it by a text `delta`
    characters longer."""

    start: int
    old_end: int
    delta: int


def check_edit(before: CheckResult, path: str, text: str) -> EditCheck | None:
    """The fast stages' diagnostics of `text` as the new text of `path` (the root
    file of `before`, a check of its fast stages), when the edit is local to a
    few declarations (the module's docstring); None when it is not."""
    model, info = before.model, before.types
    path = os.path.normpath(path)
    if info is None or len(model.specs) != 1 or model.specs[0].path != path:
        return None
    old_source = model.sources.get(path)
    if old_source is None:
        return None
    if any(d.code == _CYCLE for d in before.diagnostics) or nothing_checked(model):
        return None
    if text == old_source.text:
        return EditCheck(list(before.diagnostics), model.sources)
    try:
        return _checked(before, model, info, old_source, text)
    except RecursionError:  # a formula nested deeper than this thread's stack
        return None  # the full check runs on a deep stack (rmvdsl.util.deep)


def _checked(
    before: CheckResult, model: Model, info: TypeInfo, old_source: SourceFile, text: str
) -> EditCheck | None:
    groups = _groups(old_source, text)
    if groups is None:
        return None
    path, items = old_source.path, model.specs[0].items
    old_decls: tuple[ast.Decl, ...] = ()
    for group in groups:
        found = _declarations_in(items, group.old_start, group.old_end)
        if found is None:
            return None
        old_decls += found
    if not all(isinstance(d, _LOCAL) for d in old_decls):
        return None
    old_parse, old_damage = _parsed(path, old_source.text, [(g.old, g.old_end) for g in groups])
    new_parse, new_damage = _parsed(path, text, [(g.new, g.new_end) for g in groups])
    new_decls = tuple(d for decls, _ in new_parse for d in decls)
    if not all(isinstance(d, _LOCAL) for d in new_decls):
        return None
    if not _damage_allowed(model, old_damage, new_damage):
        return None
    old_found = tuple(d for _, found in old_parse for d in found)
    old = checked_alone(model, info, old_decls, old_found, old_damage)
    if old is None or not exports_as_before(old, info):
        return None
    new_symbols = declared_by(new_decls)
    if new_symbols is None:
        return None
    source = SourceFile(path, text)
    sources = _with_source(model.sources, source)
    moved = _shifts(groups)
    new_model = declared_again(model, (old_decls, old), (new_decls, new_symbols), sources, moved)
    new_found = tuple(d for _, found in new_parse for d in found)
    new = None
    if new_model is not None:
        new = checked_alone(new_model, info, new_decls, new_found, new_damage)
    if new is None or not same_interface(model, old, new):
        return None
    ended, started, declared = unused_changes(before, old, new, bool(new_damage[1]))
    kept = _without(before.diagnostics, [*old.diagnostics, *ended])
    edits = [g.edit for g in groups]
    placed = None if kept is None else _moved([*kept, *started], path, edits)
    if placed is None:
        return None
    diagnostics = sorted([*placed, *new.diagnostics, *declared], key=sort_key)
    return EditCheck(diagnostics, sources, far=len(groups) > 1)


Chunks = tuple[tuple[int, int], ...]  # each one's start and first line


@dataclass(frozen=True)
class _Group:
    """Chunks an edit changed, side by side: the old text's (from `old_start` to
    `old_end`) and the new text's (to `new_end`), and the smallest replacement
    inside them. The text between two groups is the same in both, moved."""

    old: Chunks
    new: Chunks
    old_end: int
    new_end: int
    edit: _Edit

    @property
    def old_start(self) -> int:
        return self.old[0][0] if self.old else self.old_end


Damage = tuple[set[str], list[tuple[int, int]]]  # names, ranges


def _parsed(
    path: str, text: str, groups: list[tuple[Chunks, int]]
) -> tuple[list[tuple[tuple[ast.Decl, ...], tuple[Diagnostic, ...]]], Damage]:
    """Each chunk's declarations and parse diagnostics (the chunks of each group,
    and where the group ends); the names and places of those with a syntax error."""
    parsed = []
    names: set[str] = set()
    ranges = []
    for chunks, end in groups:
        for (start, line), (stop, _) in itertools.pairwise([*chunks, (end, 0)]):
            decls, found, damaged = parse_chunk(path, text, start, stop, line)
            parsed.append((decls or (), found))
            if damaged:
                names |= damaged_names(text, start, stop)
                ranges.append((start, stop))
    return parsed, (names, ranges)


def _damage_allowed(model: Model, old: Damage, new: Damage) -> bool:
    """Whether the syntax errors of the changed chunks change no finding of the
    other declarations: no other chunk has one, no name another declaration reads
    in vain is quieted or no longer quieted ("undefined name" is not said of a
    name in a chunk with a syntax error), and RMV224 cannot be said (it is not
    said in such a chunk)."""
    if model.damaged_ranges.get(model.specs[0].path, []) != old[1]:
        return False
    if not old[1] and not new[1]:
        return True
    return not ((old[0] ^ new[0]) & model.unresolved or stamped_twice(model))


def _with_source(sources: SourceMap, source: SourceFile) -> SourceMap:
    """The same files, one of them with its new text."""
    copy = SourceMap()
    for each in sources:
        copy.add(source if each.path == source.path else each)
    return copy


def _edit(old: str, new: str, offset: int = 0) -> _Edit:
    """The smallest replacement that turns `old` into `new` (texts that stand at
    `offset` in the old text)."""
    start = common_prefix(old, new)
    suffix = common_suffix(old, new, min(len(old), len(new)) - start)
    return _Edit(offset + start, offset + len(old) - suffix, len(new) - len(old))


def _groups(old: SourceFile, text: str) -> list[_Group] | None:
    """The chunks the edit changed, in groups of neighbours (one, mostly: a key;
    more when the text is a few keys in different places past the check, or an
    edit of several cursors), each with the old text's chunks and the new text's
    side by side; None when more than _MOST_CHUNKS of the old text's changed."""
    scanned = last_scan(old.path, old.text)
    region = rescan(text, old.text, scanned)
    stop = len(scanned.chunks) if region.rest is None else region.rest
    if not region.chunks:
        return None
    old_end = len(old.text) if stop == len(scanned.chunks) else scanned.chunks[stop][0]
    new_end = old_end + len(text) - len(old.text)
    old_chunks, new_chunks = scanned.chunks[region.first : stop], region.chunks
    if len(old_chunks) <= _MOST_CHUNKS:
        return [_group(old.text, text, old_chunks, new_chunks, old_end, new_end)]
    # Far apart: the chunks between are the same texts, moved. Matched by their
    # text, the rest fall into groups.
    old_texts = _texts(old.text, old_chunks, old_end)
    new_texts = _texts(text, new_chunks, new_end)
    matcher = difflib.SequenceMatcher(None, old_texts, new_texts, autojunk=False)
    changed = [op for op in matcher.get_opcodes() if op[0] != "equal"]
    if sum(old_high - old_low for _, old_low, old_high, _, _ in changed) > _MOST_CHUNKS:
        return None
    old_starts = [*(start for start, _ in old_chunks), old_end]
    new_starts = [*(start for start, _ in new_chunks), new_end]
    groups = []
    for _, old_low, old_high, new_low, new_high in changed:
        old_group, new_group = old_chunks[old_low:old_high], new_chunks[new_low:new_high]
        ends = old_starts[old_high], new_starts[new_high]
        groups.append(_group(old.text, text, old_group, new_group, *ends))
    return groups


def _group(
    old_text: str, text: str, old: Chunks, new: Chunks, old_end: int, new_end: int
) -> _Group:
    old_start = old[0][0] if old else old_end
    new_start = new[0][0] if new else new_end
    edit = _edit(old_text[old_start:old_end], text[new_start:new_end], old_start)
    return _Group(old, new, old_end, new_end, edit)


def _texts(text: str, chunks: Chunks, end: int) -> list[str]:
    return [text[start:stop] for (start, _), (stop, _) in itertools.pairwise([*chunks, (end, 0)])]


def _shifts(groups: list[_Group]) -> list[tuple[int, int]]:
    """Where each group ends in the old text, and how far the edits up to it
    moved the text after it."""
    delta, found = 0, []
    for group in groups:
        delta += group.edit.delta
        found.append((group.old_end, delta))
    return found


def _declarations_in(
    items: tuple[ast.Decl, ...], start: int, end: int
) -> tuple[ast.Decl, ...] | None:
    """The declarations of the old text inside [start, end); None when one of
    them runs past it."""
    first = bisect.bisect_left(items, start, key=lambda d: d.span.start)
    found = []
    for item in items[first:]:
        if item.span.start >= end:
            break
        if item.span.end > end:
            return None
        found.append(item)
    return tuple(found)


def _without(diagnostics: list[Diagnostic], removed: list[Diagnostic]) -> list[Diagnostic] | None:
    """`diagnostics` without each of `removed` (once each); None when one of them
    is not there (the check before did not find what checking alone finds)."""
    if not removed:
        return list(diagnostics)
    wanted = Counter(removed)
    kept = []
    for diagnostic in diagnostics:
        if wanted[diagnostic] > 0:
            wanted[diagnostic] -= 1
        else:
            kept.append(diagnostic)
    return None if +wanted else kept


def _moved(diagnostics: list[Diagnostic], path: str, edits: list[_Edit]) -> list[Diagnostic] | None:
    """Each diagnostic where it now stands, each of its spans moved by the edits
    before it; None when a span touches an edit (where it stands now is not known)."""
    moved = []
    for diagnostic in diagnostics:
        spans = [diagnostic.span, *(label.span for label in diagnostic.secondary)]
        spans += [f.span for f in diagnostic.fixes]
        shifts = [_shift(span, path, edits) for span in spans]
        if None in shifts:
            return None
        if any(shifts):
            diagnostic = _shifted(diagnostic, cast("list[int]", shifts))
        moved.append(diagnostic)
    return moved


def _shift(span: Span, path: str, edits: list[_Edit]) -> int | None:
    """How far the edits (in order) moved a span of the old text: by those it is
    after (0 in another file); None when it touches one."""
    if span.path != path:
        return 0
    shift = 0
    for edit in edits:
        if span.end < edit.start or (span.end == edit.start and span.start < edit.start):
            break  # before it
        if span.start > edit.old_end or (span.start == edit.old_end and span.end > edit.old_end):
            shift += edit.delta  # after it
        else:
            return None
    return shift


def _shifted(diagnostic: Diagnostic, shifts: list[int]) -> Diagnostic:
    """The diagnostic with its spans moved, each by its own of `shifts`."""
    moving = iter(shifts)

    def move(span: Span) -> Span:
        shift = next(moving)
        return span.shifted(shift) if shift else span

    span = move(diagnostic.span)
    secondary = tuple(
        dataclasses.replace(label, span=move(label.span)) for label in diagnostic.secondary
    )
    fixes = tuple(dataclasses.replace(f, span=move(f.span)) for f in diagnostic.fixes)
    return dataclasses.replace(diagnostic, span=span, secondary=secondary, fixes=fixes)


__all__ = ["EditCheck", "check_edit", "prepare_edits"]
