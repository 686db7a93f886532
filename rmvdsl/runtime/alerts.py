"""Alerts as Kapacitor's AlertNode raises them: a level per instant, from the
conditions of each severity and their resets."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rmvdsl.runtime import influx
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.expressions import Evaluator
from rmvdsl.runtime.records import Record, seconds
from rmvdsl.runtime.values import UNSET, same_value

LEVELS = ("OK", "INFO", "WARNING", "CRITICAL")
_SEVERITY = {"info": 1, "warn": 2, "crit": 3}


def kapacitor_level(levels: Sequence[ir.AlertLevel], current: int, lookup: Any) -> int:
    """Kapacitor's AlertNode.determineLevel: a level at or above the current one
    whose condition holds; else the current one while its reset does not hold;
    else the highest level below that holds; else OK."""
    return LevelRule(levels).level(current, lookup)


class LevelRule:
    """`kapacitor_level` for one alert's levels, their conditions compiled once (an
    alert is asked at every instant a name it reads changes)."""

    def __init__(self, levels: Sequence[ir.AlertLevel]) -> None:
        self.conditions: list[Evaluator | None] = [None] * 4  # by rank; OK has none
        self.resets: list[Evaluator | None] = [None] * 4
        for level in levels:
            rank = _SEVERITY[level.severity]
            self.conditions[rank] = influx.compiled(level.condition)
            self.resets[rank] = None if level.reset is None else influx.compiled(level.reset)

    def level(self, current: int, lookup: Any) -> int:
        conditions = self.conditions
        for rank in range(3, max(current, 1) - 1, -1):
            condition = conditions[rank]
            if condition is not None and condition(lookup) is True:
                return rank
        reset = self.resets[current]
        if reset is not None and reset(lookup) is not True:
            return current
        for rank in range(current, 0, -1):
            condition = conditions[rank]
            if condition is not None and condition(lookup) is True:
                return rank
        return 0


class AlertState:
    def __init__(self, alert: ir.Alert) -> None:
        self.alert = alert
        self.reads = frozenset(alert.reads)
        self.current: dict[str, Any] = {}
        self.level = 0
        self.rule = LevelRule(alert.levels)

    def instant(self, time: int, changes: list[tuple[str, Any]]) -> Record | None:
        touched = changed = False
        current = self.current
        for name, value in changes:
            if name in self.reads:
                touched = True
                if not changed:
                    changed = not same_value(current.get(name, UNSET), value)
                current[name] = value
        if not touched:
            return None
        previous = self.level
        if changed:  # the level of the same values is the same: `kapacitor_level` of
            # its own result gives it again
            self.level = self.rule.level(previous, current.get)
        if self.level == previous and (self.alert.state_changes_only or self.level == 0):
            return None
        if self.level == 0 and self.alert.no_recoveries:
            return None
        return {
            "kind": "alert",
            "alert": self.alert.name,
            "id": self.alert.id,
            "time": seconds(time),
            "level": LEVELS[self.level],
            "previous": LEVELS[previous],
            "message": self.alert.message,
            "values": {n: self.current[n] for n in self.alert.reads if n in self.current},
        }
