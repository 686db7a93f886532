"""What a fleet of results adds up to: recordings by status, and per property the
recordings it failed in and the time it was false in all; the worst runs first."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from rmvdsl.runtime.wording import counted
from rmvdsl.tools.fleet.worker import STATUSES


@dataclass
class PropertyTotal:
    recordings: int = 0  # recordings where it was false at some time
    false_seconds: float = 0.0


@dataclass
class FleetSummary:
    total: int
    statuses: dict[str, int] = field(default_factory=lambda: dict.fromkeys(STATUSES, 0))
    properties: dict[str, PropertyTotal] = field(default_factory=dict)
    messages: int = 0

    def add(self, result: dict[str, Any]) -> None:
        self.statuses[result["status"]] += 1
        self.messages += result["messages"]
        for name, seconds in false_time(result).items():
            total = self.properties.setdefault(name, PropertyTotal())
            total.recordings += 1
            total.false_seconds += seconds

    @property
    def done(self) -> int:
        return sum(self.statuses.values())

    def exit_code(self) -> int:
        """0 all pass, 1 any violation or intrusion, 2 every recording unreadable."""
        if self.statuses["violations"] or self.statuses["intrusions"]:
            return 1
        unread = self.statuses["unreadable"] + self.statuses["failed"]
        return 2 if self.done and unread == self.done else 0

    def lines(self) -> list[str]:
        shown = [f"{counted(n, 'recording', grouped=True)} {_WORDS[s]}"
                 for s, n in self.statuses.items() if n]  # fmt: skip
        messages = counted(self.messages, "message", grouped=True)
        head = (f"{counted(self.done, 'recording', grouped=True)} of {self.total:,} replayed "
                f"({messages}): " + ", ".join(shown))  # fmt: skip
        out = [head]
        for name, total in sorted(self.properties.items()):
            out.append(f"  {name}: false in {counted(total.recordings, 'recording', grouped=True)}"
                       f", {total.false_seconds:g} s in all")  # fmt: skip
        return out


_WORDS = {"pass": "passed", "violations": "with violations", "intrusions": "with intrusions",
          "incomplete": "not matching the spec", "unreadable": "unreadable",
          "failed": "failed"}  # fmt: skip


def records(result: dict[str, Any]) -> list[dict[str, Any]]:
    return [json.loads(text) for text in result["records"]]


def false_time(result: dict[str, Any]) -> dict[str, float]:
    """Per property, the seconds it was false in this recording (present only for
    properties false at some time)."""
    found: dict[str, float] = {}
    for text in result["records"]:
        if '"verdict"' not in text or '"false"' not in text:
            continue
        record = json.loads(text)
        if record.get("kind") == "verdict" and record.get("verdict") == "false":
            end = record.get("to")
            length = float(end) - float(record["from"]) if end is not None else 0.0
            found[record["property"]] = found.get(record["property"], 0.0) + length
    return found


def worst(results: list[dict[str, Any]], most: int) -> list[dict[str, Any]]:
    """The runs with violations, most time false first."""
    failing = [r for r in results if r["status"] == "violations"]
    failing.sort(key=lambda r: (-sum(false_time(r).values()), -r["violations"], r["path"]))
    return failing[:most]
