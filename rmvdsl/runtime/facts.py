"""What one walk over a compiled formula finds: how far it looks ahead and back,
its propositions, whether it looks into the past (docs/semantics.md, "horizon").
The checker and the monitor both read it."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, TypeVar

from rmvdsl.runtime.signal import _INFINITY


class Facts(NamedTuple):
    """What one walk over a compiled formula finds (docs/semantics.md, "horizon")."""

    future: Any  # how far it looks ahead
    past: Any  # how far it looks back (infinite under a `since` with no bound)
    propositions: tuple[str, ...]  # left to right, each once
    has_past: bool  # a `since` (or `once`, `historically`) inside
    reach: Any = 0  # how much history a monitor keeps for it, ahead and back (finite)


# The facts of the formulas asked about lately, by identity: the checker asks them
# of each property's formula several times a question.
_KNOWN_FACTS: dict[int, tuple[Any, Facts]] = {}
KNOWN_FACTS = 4096
T = TypeVar("T")


def remembered(table: dict[int, tuple[Any, T]], formula: Any, make: Callable[[Any], T]) -> T:
    """`make(formula)`, kept in `table` by the formula's identity (each entry keeps
    its formula alive, so its id is its own until the table is cleared, at
    KNOWN_FACTS entries)."""
    known = table.get(id(formula))
    if known is not None and known[0] is formula:
        return known[1]
    found = make(formula)
    if len(table) >= KNOWN_FACTS:
        table.clear()
    table[id(formula)] = (formula, found)
    return found


def facts(formula: Any) -> Facts:
    """Horizon, propositions and past-ness in one traversal, by a loop (formulas can
    be 100,000 levels deep). The monitor's nodes compute the same horizon each for
    itself; a test keeps the two equal. `not` changes none of them: the checker's
    `("not", f)` of a formula is answered from the formula's."""
    while formula[0] == "not":
        formula = formula[1]
    return remembered(_KNOWN_FACTS, formula, _walked_facts)


def _walked_facts(formula: Any) -> Facts:
    done: dict[int, tuple[Any, Any, bool, Any]] = {}
    names: dict[str, None] = {}
    stack: list[tuple[Any, bool]] = [(formula, False)]
    while stack:
        node, expanded = stack.pop()
        children = [c for c in node[1:] if isinstance(c, tuple)]
        if not expanded:
            if node[0] == "prop":
                names.setdefault(node[1], None)
            stack.append((node, True))
            stack.extend((child, False) for child in reversed(children))
            continue
        parts = [done[id(child)] for child in children]
        future = max((p[0] for p in parts), default=0)
        past = max((p[1] for p in parts), default=0)
        backwards = node[0] == "since" or any(p[2] for p in parts)
        reach = max((p[3] for p in parts), default=0)
        if node[0] == "until":
            future += node[2]
        elif node[0] == "since" and node[2] is None:
            past = _INFINITY
        elif node[0] == "since":
            past, reach = past + node[2], reach + node[2]
        elif node[0] == "dur":
            future += node[1]
        done[id(node)] = (future, past, backwards, reach)
    future, past, backwards, reach = done[id(formula)]
    return Facts(future, past, tuple(names), backwards, future + reach)
