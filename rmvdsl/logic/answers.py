"""What a satisfiability question answers: the verdict (yes, no, unknown), its witness
trace and how it was found, as the cache and the editor store them."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from rmvdsl.runtime.values import exact_text as number

YES, NO, UNKNOWN = "yes", "no", "unknown"


@dataclass(frozen=True)
class Witness:
    """A trace (state i on [times[i], times[i+1]), the last until `end`) and the
    time `at` where the formulas have the value claimed."""

    times: tuple[Fraction, ...]
    states: tuple[frozenset[str], ...]
    at: Fraction
    end: Fraction
    names: tuple[str, ...]

    def timeline(self) -> list[str]:
        """One line per segment, with a bar per proposition."""
        width = max((len(n) for n in self.names), default=0)
        stops = [*self.times[1:], self.end]
        rows = []
        for start, stop, state in zip(self.times, stops, self.states, strict=True):
            held = ", ".join(n for n in self.names if n in state) or "(none)"
            rows.append(f"[{number(start)}, {number(stop)})  {held}")
        chart = [f"{name.ljust(width)}  {self._bar(name)}" for name in self.names]
        return [f"at t = {number(self.at)}:", *rows, *chart]

    def _bar(self, name: str, columns: int = 40) -> str:
        span = self.end - self.times[0]
        cells = []
        for column in range(columns):
            t = self.times[0] + span * Fraction(2 * column + 1, 2 * columns)
            index = max(i for i, start in enumerate(self.times) if start <= t)
            cells.append("#" if name in self.states[index] else ".")
        return "".join(cells) + f"  0..{number(self.end)}"

    def as_json(self) -> dict[str, Any]:
        return {
            "at": _json_number(self.at),
            "end": _json_number(self.end),
            "trace": [
                {"t": _json_number(t), "props": sorted(s)}
                for t, s in zip(self.times, self.states, strict=True)
            ],
        }

    def jsonl(self, unit: str | None = None) -> str:
        """The trace in the format `rmv eval` reads: its times in `unit` (the spec's
        `time unit`), said on the first line when it is not seconds."""
        from rmvdsl.runtime.engine import to_json  # the runtime's one JSON number rule

        lines = [to_json({"unit": unit})] if unit not in (None, "s") else []
        lines += [
            to_json({"t": t, "props": sorted(s)})
            for t, s in zip(self.times, self.states, strict=True)
        ]
        lines.append(to_json({"t": self.end, "end": True}))
        return "\n".join(lines) + "\n"

    @classmethod
    def from_json(cls, data: dict[str, Any], names: Sequence[str]) -> Witness:
        return cls(
            tuple(Fraction(str(item["t"])) for item in data["trace"]),
            tuple(frozenset(item["props"]) for item in data["trace"]),
            Fraction(str(data["at"])),
            Fraction(str(data["end"])),
            tuple(names),
        )


@dataclass(frozen=True)
class Answer:
    value: str  # yes, no or unknown
    exact: bool
    witness: Witness | None = None
    core: tuple[int, ...] = ()  # for "no" on several formulas: a conflicting subset
    note: str = ""
    timed_out: bool = False

    def as_json(self) -> dict[str, Any]:
        return {
            "value": self.value,
            "exact": self.exact,
            "witness": self.witness.as_json() if self.witness else None,
            "names": list(self.witness.names) if self.witness else [],
            "core": list(self.core),
            "note": self.note,
            "timed_out": self.timed_out,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Answer:
        witness = data.get("witness")
        return cls(
            data["value"],
            data["exact"],
            Witness.from_json(witness, data["names"]) if witness else None,
            tuple(data["core"]),
            data["note"],
            bool(data.get("timed_out", False)),
        )


def _json_number(value: Fraction) -> int | float | str:
    if value.denominator == 1:
        return value.numerator
    as_float = float(value)
    return as_float if Fraction(str(as_float)) == value else str(value)
