"""Nested windows of one kind as one window, for the solver's questions.

`eventually[<=a] eventually[<=b] p` is `eventually[<=a+b] p` (a time within a of
one within b of now is a time within a+b, and each such time is one), and so for
`once` in `once`, `always` in `always` and `historically` in `historically`
(each the negation of the other kind around a negation). The identity holds for
the three-valued verdicts too: either side is true where p holds somewhere in the
window, false where p is known false all over it, unknown otherwise. A `<` on
either side makes the merged window open at its end; a bound of `< 0` (an empty
window) or `= T` (one instant) is left as written.

The solver encoded each nested window with times of its own, so ten nested
`eventually[<=1s]` made questions many times harder than one `eventually[<=10s]`,
and two such properties, equal in meaning, were never found redundant; the
monitor ran a node per window. The solver's questions
(rmvdsl.logic.search.Question) and the monitors (rmvdsl.runtime.rmtld3.Monitor)
take the merged formulas; the cache keys, the generated code and the reports
keep the formulas as written.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rmvdsl.runtime.facts import remembered

_WINDOWS = ("until", "since")


# Formulas already flattened, by identity, with what they became: a monitor is
# built for each witness a question replays (up to 200), and a walk per build
# was half the cost of building it.
_KNOWN: dict[int, tuple[Any, Any]] = {}


def flattened(formula: Any) -> Any:
    """The formula with each window directly inside another of its kind merged
    into it, and double negations dropped (a loop: formulas nest deeply); the
    formula itself where nothing merges."""
    return remembered(_KNOWN, formula, _walked)


def _walked(formula: Any) -> Any:
    return bottom_up(formula, _simplified)


def bottom_up(formula: Any, rebuild: Callable[[Any, list[Any]], Any]) -> Any:
    """`rebuild(node, fields)` of every node, children first, `fields` the node's
    items after its tag with each child already rebuilt; by a loop (formulas nest
    deeply), a node shared by several parents rebuilt once."""
    done: dict[int, Any] = {}
    stack: list[tuple[Any, bool]] = [(formula, False)]
    while stack:
        node, visited = stack.pop()
        if id(node) in done:
            continue
        children = [c for c in node[1:] if _is_node(c)]
        if not visited:
            stack.append((node, True))
            stack.extend((c, False) for c in children if id(c) not in done)
            continue
        fields = [done[id(c)] if _is_node(c) else c for c in node[1:]]
        done[id(node)] = rebuild(node, fields)
    return done[id(formula)]


def _is_node(value: Any) -> bool:
    """A formula's node: a tuple (or, as a host keeps them, a list) led by its tag."""
    return isinstance(value, tuple | list) and bool(value) and isinstance(value[0], str)


def _simplified(node: Any, fields: list[Any]) -> Any:
    tag = node[0]
    if tag == "not" and fields[0][0] == "not":
        return fields[0][1]
    if tag in _WINDOWS and _mergeable(tag, (tag, *fields)) and _mergeable(tag, fields[3]):
        op, bound, left, (_, inner_op, inner_bound, _, inner) = fields
        merged_op = "<=" if op == inner_op == "<=" else "<"
        return _made(node, [merged_op, bound + inner_bound, left, inner])
    return _made(node, fields)


def _mergeable(tag: str, node: Any) -> bool:
    """`eventually` (`once`, by `tag`) with a window that merges: `<=` any bound,
    `<` a positive one; `true` on the left."""
    if len(node) != 5 or node[0] != tag or node[2] is None:
        return False
    op, bound, left = node[1], node[2], node[3]
    if not _is_node(left) or tuple(left) != ("const", True):
        return False
    return bool(op == "<=" or (op == "<" and bound > 0))


def _made(node: Any, fields: list[Any]) -> Any:
    """A node of the same kind (named tuple, tuple or list) with these fields: the
    node itself where none changed."""
    if all(new is old for new, old in zip(fields, node[1:], strict=True)):
        return node
    if isinstance(node, list):
        return [node[0], *fields]
    make = getattr(type(node), "_make", None)
    return make([node[0], *fields]) if make is not None else (node[0], *fields)
