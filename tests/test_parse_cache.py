"""The parser keeps each declaration's tree by its text and reuses it, moved to
where the declaration now starts (an editor re-parses at every keystroke). A parse
that reuses trees must equal a fresh parse in everything: the trees, every span,
every string literal's offsets, every diagnostic and where it points."""

from __future__ import annotations

import copy
import dataclasses
import pickle
import random
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import pytest
from conftest import EXAMPLES

from rmvdsl.grammar import ast, shift
from rmvdsl.grammar import parser as parsing
from rmvdsl.lang.source import SourceFile, Span
from rmvdsl.util.bounded import Bounded

SPECS = sorted(p for p in EXAMPLES.rglob("*.rmv") if p.name != "latin1.rmv")  # not UTF-8
PIECES = ["", "x", "\n", "  ", "{", "}", '"', "\U0001f697", "event E when a > 1\n", "//", "->"]


def _positions(value: Any, into: list[Any]) -> list[Any]:
    """Every span and offset in a tree, in order."""
    if isinstance(value, Span):
        into.append(value)
    elif isinstance(value, (tuple, list)):
        for item in value:
            _positions(item, into)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for item in dataclasses.fields(value):
            inner = getattr(value, item.name)
            into.append(inner) if item.name == "offsets" else _positions(inner, into)
    return into


def _parse(path: str, text: str) -> parsing.ParsedSpec:
    return parsing.parse_source(SourceFile(path, text))


def _same(a: parsing.ParsedSpec, b: parsing.ParsedSpec) -> None:
    assert a.spec == b.spec
    assert _positions(a.spec, []) == _positions(b.spec, [])
    assert sorted(map(repr, a.diagnostics)) == sorted(map(repr, b.diagnostics))
    assert a.damaged_names == b.damaged_names
    assert sorted(a.damaged_ranges) == sorted(b.damaged_ranges)


@pytest.mark.parametrize("spec", SPECS, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_a_parse_reusing_trees_equals_a_fresh_one(spec):
    text = spec.read_text(encoding="utf-8")
    rng = random.Random(spec.name)
    for _ in range(8):
        at = rng.randrange(len(text) + 1)
        cut = min(len(text), at + rng.randrange(3))
        edited = text[:at] + rng.choice(PIECES) + text[cut:]
        parsing._CHUNK_CACHE.clear()
        _parse(str(spec), text)  # the trees of the text before the edit
        reused = _parse(str(spec), edited)
        parsing._CHUNK_CACHE.clear()
        _same(reused, _parse(str(spec), edited))
        text = edited


def test_the_cache_is_used_and_bounded():
    spec = EXAMPLES / "carla" / "abs.rmv"
    text = spec.read_text(encoding="utf-8")
    parsing._CHUNK_CACHE.clear()
    _parse(str(spec), text)
    size = len(parsing._CHUNK_CACHE)
    assert size > 20
    _parse(str(spec), "\n" + text)  # every declaration moved by one character
    assert len(parsing._CHUNK_CACHE) <= size + 1  # the first chunk grew; all others reused
    assert parsing._CHUNK_CACHE_SIZE >= 10_000


def test_a_file_larger_than_the_cache_keeps_its_own_chunks(monkeypatch):
    """The bound grows to twice the chunks of the largest file parsed: a file of
    more declarations than the cache holds is not parsed from scratch each time."""
    monkeypatch.setattr(parsing, "_CHUNK_CACHE", Bounded(10))
    text = "".join(f'topic T{i}: std_msgs/msg/Bool = "/t{i}"\n' for i in range(60))
    parses = []
    original = parsing.ChunkParser.parse

    def counting(self):
        parses.append(self)
        return original(self)

    monkeypatch.setattr(parsing.ChunkParser, "parse", counting)
    parsing._CHUNK_CACHE.clear()
    _parse("big.rmv", text)
    first = len(parses)
    assert first >= 60
    _parse("big.rmv", "\n" + text)
    assert len(parses) - first <= 1  # only the chunk that changed


def _moved_spec() -> tuple[Any, Any]:
    """A spec's declarations as parsed, and as moved by a comment typed before them."""
    text = (EXAMPLES / "carla" / "abs.rmv").read_text(encoding="utf-8")
    parsing._CHUNK_CACHE.clear()
    parsed = _parse("lazy.rmv", text).spec
    moved = _parse("lazy.rmv", "// moved\n" + text).spec
    return parsed, moved


def test_a_moved_declaration_moves_its_trees_when_first_read():
    """What the parser reuses is moved lazily: a copy holds its span, its name and
    its leaf fields; its other trees are moved on the first read, once, and are
    then what a fresh parse gives."""
    _, moved = _moved_spec()
    events = [d for d in moved.items if isinstance(d, ast.EventDecl)]
    assert events
    for decl in events:
        assert shift.MOVED_FROM in decl.__dict__ and "expr" not in decl.__dict__
        assert decl.name.span.start > 0  # the name is moved at once
        first = decl.expr
        assert decl.expr is first  # one object for every reader
    parsing._CHUNK_CACHE.clear()
    fresh = _parse("lazy.rmv", "// moved\n" + (EXAMPLES / "carla" / "abs.rmv").read_text())
    assert _positions(moved, []) == _positions(fresh.spec, [])


def test_readers_in_threads_get_the_same_moved_trees():
    _, moved = _moved_spec()
    decls = [d for d in moved.items if shift.MOVED_FROM in d.__dict__]
    start = threading.Barrier(4)

    def read() -> list[int]:
        start.wait()
        return [id(child) for decl in decls for child in ast.walk(decl)]

    with ThreadPoolExecutor(4) as pool:
        seen = list(pool.map(lambda _: read(), range(4)))
    assert all(ids == seen[0] for ids in seen)


def test_a_moved_declaration_behaves_as_a_node():
    """Copied, pickled, compared, moved again, given a doc comment, asked for what
    it has not: as the declaration a fresh parse gives."""
    parsed, moved = _moved_spec()
    decl = next(d for d in moved.items if isinstance(d, ast.PropertyDecl))
    original = next(d for d in parsed.items if isinstance(d, ast.PropertyDecl))
    assert not hasattr(decl, "no_such_field")
    with pytest.raises(AttributeError):
        decl.__no_such_dunder__  # noqa: B018
    assert copy.deepcopy(decl) == decl == original  # spans take no part in equality
    assert pickle.loads(pickle.dumps(decl)) == decl
    again = shift.shifted(decl, 5)  # a moved copy moved further: from its original
    assert again.span.start == decl.span.start + 5
    assert _positions(again, []) == _positions(shift.shifted(original, 5 + 9), [])
    documented = shift.with_field(shift.shifted(original, 1), "doc", "what it means")
    assert documented.doc == "what it means" and documented.body == original.body
    assert shift.shifted(documented, 2).doc == "what it means"  # its own leaves, moved on


def test_after_the_warm_up_a_keystroke_compiles_no_mover():
    """A class's mover is compiled when the class is first moved: an editor's
    warm-up (rmvdsl.editor.workspace.warm_up) writes them all, so that its first
    keystrokes after opening a spec do not."""
    from rmvdsl.editor.workspace import warm_up

    written = dict(shift._SHIFTERS)
    shift._SHIFTERS.clear()
    shift._SHIFTERS.update({k: written[k] for k in (Span, tuple, list)})
    try:
        warm_up()
        ready = set(shift._SHIFTERS)
        for spec in SPECS:
            text = spec.read_text(encoding="utf-8")
            _parse(str(spec), text)
            moved = _parse(str(spec), "// moved\n" + text + "\nevent E when\n")
            _positions(moved.spec, [])  # every tree read: each moved at once
            assert set(shift._SHIFTERS) == ready, spec
    finally:
        shift._SHIFTERS.clear()
        shift._SHIFTERS.update(written)
