"""Moving a tree's spans: a declaration reused by the parser where it now stands.

An edit moves every later declaration, so this runs over most of a file at each
keystroke. A class's mover is written once, from its field names: it copies a node
without `__init__` (the node was checked when first built), moves its span and its
string offsets, and copies the fields that hold only leaves (`str`, `Fraction`...)
as they are.

Declarations (classes that set `_moved_on_read`) are moved lazily: a copy holds
its span and leaf fields, and its sub-trees are all moved when one of them is
first read (`rmvdsl.grammar.ast.Node.__getattr__` calls `moved_field`). An
editor's check reuses most declarations' findings by their text
(rmvdsl.check.memo) and never reads their sub-trees: copying them was two thirds
of a keystroke's parse. Below a declaration, nodes are moved at once (moving each
field on its first read cost more than copying a whole tree that is read).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from fractions import Fraction
from types import ModuleType
from typing import Any, cast

from rmvdsl.lang.source import Span

# Where a lazily moved node keeps what it is a copy of: (the node, the distance).
MOVED_FROM = "_moved_from"
# Where a parsed declaration keeps what the checker's stages found in it (each
# stage's entries, rmvdsl.check.memo): one dict per parse of a declaration's text,
# shared by every copy of it the parser hands out, moved or not.
FINDINGS = "_findings"

Mover = Callable[[Any, int], Any]


def shifted(value: Any, delta: int) -> Any:
    """A tree (syntax nodes, diagnostics, and what they hold) with every span, and
    every offset of a string literal, moved by `delta` characters."""
    return _SHIFTERS[type(value)](value, delta)


def moved_field(node: Any, name: str) -> Any:
    """A field of a lazily moved node: its sub-trees are moved now (once: every
    reader, in any thread, gets the same objects)."""
    values = node.__dict__
    origin = values.get(MOVED_FROM)
    if origin is None or name.startswith("__"):
        raise AttributeError(name)
    original, delta = origin
    for field in _DEFERRED[type(node)]:
        value = getattr(original, field)
        moved = value if type(value) in _LEAVES else _SHIFTERS[type(value)](value, delta)
        values.setdefault(field, moved)
    if name not in values:
        raise AttributeError(name)
    return values[name]


def keep_findings(decls: tuple[Any, ...]) -> None:
    """Give each declaration of a chunk the parser keeps (one without syntax
    errors) a place for findings."""
    for decl in decls:
        decl.__dict__[FINDINGS] = {}


def findings(decl: Any) -> dict[Any, Any] | None:
    """The findings kept with the parse this declaration is (a copy of: a copy
    holds its original's); None for a declaration the parser did not keep, or kept
    with syntax errors."""
    return decl.__dict__.get(FINDINGS)


def with_field(node: Any, name: str, value: Any) -> Any:
    """A copy of a node with one leaf field replaced, its sub-trees shared (a moved
    declaration's are not moved by it): a declaration's doc comment is attached so."""
    copy = object.__new__(type(node))
    copy.__dict__.update(node.__dict__)
    copy.__dict__[name] = value
    return copy


def write_movers(module: ModuleType) -> None:
    """Write the mover of every dataclass `module` defines now: a class's mover is
    compiled when it is first moved, and an editor's first keystrokes after
    opening a spec compiled those of the classes they moved (1.5 ms here; an
    editor calls this while it opens its first document)."""
    for value in vars(module).values():
        if (
            isinstance(value, type)
            and dataclasses.is_dataclass(value)
            and value.__module__ == module.__name__
        ):
            _SHIFTERS[value]  # written on first use (_Shifters.__missing__)


def _moved_items(items: tuple[Any, ...] | list[Any], delta: int) -> Any:
    moved = [item if type(item) in _LEAVES else _SHIFTERS[type(item)](item, delta)
             for item in items]  # fmt: skip
    return tuple(moved) if type(items) is tuple else moved


def _unmoved(value: Any, delta: int) -> Any:
    return value


_LEAVES = frozenset({str, int, bool, float, Fraction, type(None)})
# Fields whose annotation says they hold only leaves are copied as they are.
_LEAF_ANNOTATIONS = frozenset({"str", "int", "bool", "float", "Fraction", "None", "Severity"})


class _Shifters(dict[type, Mover]):
    """A mover per class, written when the class is first met."""

    def __missing__(self, kind: type) -> Mover:
        mover = _write_mover(kind) if dataclasses.is_dataclass(kind) else _unmoved
        self[kind] = mover
        return mover


# The fields a lazily moved class moves when first read, by class.
_DEFERRED: dict[type, tuple[str, ...]] = {}


def tree_fields(kind: type) -> tuple[str, ...]:
    """The fields of a dataclass whose annotation says they may hold trees (not
    leaves, not its span or string offsets): what a mover moves, and what
    rmvdsl.grammar.ast.walk visits."""
    names = _TREE_FIELDS.get(kind)
    if names is None:
        names = _TREE_FIELDS[kind] = tuple(
            item.name for item in dataclasses.fields(kind) if _holds_trees(item)
        )
    return names


_TREE_FIELDS: dict[type, tuple[str, ...]] = {}


def _holds_trees(item: dataclasses.Field[Any]) -> bool:
    annotation = str(item.type).replace(" ", "")
    leaves = set(annotation.split("|")) <= _LEAF_ANNOTATIONS
    return not leaves and annotation != "Span" and item.name != "offsets"


def _write_mover(kind: type) -> Mover:
    trees = tree_fields(kind)
    fields = dataclasses.fields(kind)
    deferred = [f.name for f in fields if f.name in trees and _deferrable(kind, f)]
    _DEFERRED[kind] = tuple(deferred)
    lines = [
        "def move(value, delta):",
        "    fields = value.__dict__",
        "    copy = new(kind)",
        "    moved = copy.__dict__",
    ]
    if deferred:
        # A moved copy moved again: its sub-trees come from its original, further.
        # Its findings are its original's (one dict per parse).
        lines += [
            "    origin = fields.get(lazy)",
            "    moved[lazy] = (value, delta) if origin is None else "
            "(origin[0], origin[1] + delta)",
            "    kept = fields.get(found)",
            "    if kept is not None:",
            "        moved[found] = kept",
        ]
    else:
        lines.append("    moved.update(fields)")
    for item in fields:
        field = repr(item.name)
        if item.name in deferred:
            continue
        if item.name == "offsets":
            lines.append(f"    moved[{field}] = tuple([o + delta for o in fields[{field}]])")
        elif str(item.type).replace(" ", "") == "Span":
            lines.append(f"    moved[{field}] = span(fields[{field}], delta)")
        elif item.name in trees:
            lines.append(f"    old = fields[{field}]")
            lines.append("    if type(old) not in leaves:")
            lines.append(f"        moved[{field}] = movers[type(old)](old, delta)")
            if deferred:
                lines.append(f"    else:\n        moved[{field}] = old")
        elif deferred:
            lines.append(f"    moved[{field}] = fields[{field}]")
    lines.append("    return copy")
    scope = {
        "new": object.__new__,
        "kind": kind,
        "lazy": MOVED_FROM,
        "found": FINDINGS,
        "span": Span.shifted,
        "leaves": _LEAVES,
        "movers": _SHIFTERS,
    }
    exec("\n".join(lines), scope)  # the code is written above, from field names only
    return cast("Mover", scope["move"])


def _deferrable(kind: type, item: dataclasses.Field[Any]) -> bool:
    """Whether a lazily moved class's tree field may be moved when first read: not
    the declaration's name (every check reads it, to declare it), and no class
    attribute (a default) would answer for it before it is there."""
    lazy = getattr(kind, "_moved_on_read", False)
    return lazy and str(item.type).strip() != "Ident" and not hasattr(kind, item.name)


_SHIFTERS = _Shifters({Span: Span.shifted, tuple: _moved_items, list: _moved_items})
