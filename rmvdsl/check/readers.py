"""Who reads each name, for an editor's edit path (rmvdsl.check.edit): how often
each name of a check is referred to, counted once per check, and the RMV203
("never used") warnings an edit ends and starts."""

from __future__ import annotations

import weakref
from collections import Counter
from operator import itemgetter
from typing import TYPE_CHECKING, Protocol, cast

from rmvdsl.check.model import Model, Reference, ReusedReferences, Symbol
from rmvdsl.check.names import unused_warning, whitelisted_topics
from rmvdsl.lang.diagnostics import Diagnostic

if TYPE_CHECKING:
    from rmvdsl.check import CheckResult


class Declarations(Protocol):
    """What declarations declare and read (rmvdsl.check.alone.Alone)."""

    @property
    def symbols(self) -> dict[str, Symbol]: ...

    @property
    def uses(self) -> Counter[str]: ...


def unused_changes(
    before: CheckResult, old: Declarations, new: Declarations, damaged: bool
) -> tuple[list[Diagnostic], list[Diagnostic], list[Diagnostic]]:
    """The RMV203 warnings the edit ends, and those it starts: of names declared
    before it (where they stood then), and of the names it declares. A text with
    a syntax error (`damaged`: the new one) reports none; after one, every unused
    name is reported again."""
    model = before.model
    if damaged:
        return [d for d in before.diagnostics if d.code == "RMV203"], [], []
    counts = use_counts(model)
    whitelisted = whitelisted_topics(model) if model.whitelists else set()

    def unused(symbol: Symbol) -> list[Diagnostic]:
        found = unused_warning(symbol, whitelisted)
        return [] if found is None else [found]

    ended, started, declared = [], [], []
    gone = old.symbols.keys() - new.symbols.keys()
    for name, symbol in new.symbols.items():
        if name not in old.symbols and new.uses[name] == 0:
            declared += unused(symbol)
    if any(model.damaged_ranges.values()):  # the check before reported none
        # The names read after the edit, by set operations (a spec has thousands).
        dropped = {n for n in old.uses if counts[n] - old.uses[n] + new.uses[n] <= 0}
        read = (counts.keys() - dropped) | new.uses.keys()
        for name in model.symbols.keys() - read - gone:
            started += unused(model.symbols[name])
        return [], started, declared
    for name in gone:
        if counts[name] == 0:
            ended += unused(model.symbols[name])
    for name in new.uses.keys() - old.uses.keys():
        if name in model.symbols and counts[name] == 0:
            ended += unused(model.symbols[name])
    for name in old.uses.keys() - new.uses.keys():
        if name not in gone and counts[name] == old.uses[name]:
            started += unused(model.symbols[name])
    return ended, started, declared


# The model counted last (not kept alive by this: a closed document's is let go).
_COUNTED: list[tuple[weakref.ref[Model], Counter[str]]] = []


def prepare_edits(result: CheckResult) -> None:
    """Work out now what check_edit reads of `result` (an editor calls this beside
    the check, not at the next keystroke)."""
    use_counts(result.model)


def use_counts(model: Model) -> Counter[str]:
    """How often each name is referred to in the whole model (once per model)."""
    if _COUNTED and _COUNTED[0][0]() is model:
        return _COUNTED[0][1]
    counts: Counter[str] = Counter()
    for use in model.uses:
        if type(use) is ReusedReferences:
            counts.update(map(itemgetter(0), use.found))
        else:
            counts[cast("Reference", use).name] += 1
    _COUNTED[:] = [(weakref.ref(model), counts)]
    return counts
