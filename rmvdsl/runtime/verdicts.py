"""Each property's verdicts as the runtime gives them out: maximal segments (one is
written when it closes; the open one is `pending`, the node's current verdict),
cut where late input made them unknown, and revised when it came after they were
given out (docs/runtime.md, "Late input")."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from fractions import Fraction
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.records import Record
from rmvdsl.runtime.segments import Segment, continues
from rmvdsl.runtime.uncertain import Uncertain


class Segments:
    """`write(record)` gives a record out; `violated(prop, segment)` runs when a
    false segment opens (the property's actions)."""

    def __init__(
        self, properties: Iterable[ir.Property], write: Callable[[Record], None],
        violated: Callable[[ir.Property, list[Any]], None],
    ) -> None:  # fmt: skip
        self.write = write
        self.violated = violated
        self.pending: dict[str, list[Any]] = {}
        self.uncertain = {p.name: Uncertain() for p in properties}
        # The end of the verdicts given out so far, and whether it is closed.
        self.given_to: dict[str, tuple[Fraction, bool]] = {}

    def add(self, prop: ir.Property, given: Iterable[Segment]) -> None:
        """Segments a property's monitor decided, in order."""
        uncertain = self.uncertain[prop.name]
        for segment in given:
            self.given_to[prop.name] = (segment[1], segment[3])
            for piece in uncertain.mask(segment):
                self._add(prop, *piece)

    def _add(
        self, prop: ir.Property, start: Any, stop: Any, start_closed: bool, stop_closed: bool,
        verdict: str,
    ) -> None:  # fmt: skip
        """One segment in order: joined to the one before when it continues it."""
        name = prop.name
        value = verdict.split(" ")[0]
        segment = [start, stop, start_closed, stop_closed, value]
        pending = self.pending.get(name)
        if pending is not None and continues(pending, segment):
            pending[1], pending[3] = stop, stop_closed
            return
        if pending is not None:
            self.flush(name)
        self.pending[name] = segment
        if value == "false":
            self.violated(prop, segment)

    def unknown(self, name: str, low: Fraction, high: Fraction | None) -> list[Any]:
        """The verdicts of `name` on [low, high] (no end yet: None) are unknown; the
        interval, whose end the caller may set later."""
        interval = self.uncertain[name].add(low, high)
        self._revise(name, low, high)
        return interval

    def _revise(self, name: str, low: Fraction, high: Fraction | None) -> None:
        """What was given out on [low, high] is unknown: one record says so, marked
        `revised` (it overlaps records before it)."""
        given = self.given_to.get(name)
        if given is None or low > given[0] or (low == given[0] and not given[1]):
            return
        if name in self.pending:
            self.flush(name)
        stop, stop_closed = given if high is None or high >= given[0] else (high, True)
        self.pending[name] = [low, stop, True, stop_closed, "unknown", True]

    def flush(self, name: str) -> None:
        start, stop, start_closed, stop_closed, value, *revised = self.pending.pop(name)
        bounds = ("[" if start_closed else "(") + ("]" if stop_closed else ")")
        record = {
            "kind": "verdict", "property": name, "verdict": value, "from": start,
            "to": stop, "bounds": bounds,
        }  # fmt: skip
        if revised:
            record["revised"] = True
        self.write(record)

    def flush_all(self) -> None:
        for name in list(self.pending):
            self.flush(name)
