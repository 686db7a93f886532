"""What a replay's timeline shows, as geometry in the recording's seconds: one
layout that every painter (SVG, PNG) draws the same way.

Rows of the top panel, top to bottom: each property's verdict (true green, false
red, unknown grey), each transducer's state, each boolean event; below it, the
numeric variables and value events as step lines (six at most); alert level
changes and intrusion starts as vertical marks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from math import isfinite
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Record

VERDICT_COLOURS = {"true": "#2e7d32", "false": "#c62828", "unknown": "#9e9e9e"}
STATE_FILL, STATE_EDGE = "#bbdefb", "#1565c0"
EVENT_FILL = "#ffb300"
ALERT_MARK, INTRUSION_MARK = "#ef6c00", "#6a1b9a"
MOST_LINES = 6


@dataclass(frozen=True)
class Bar:
    row: int  # index into Timeline.rows, 0 at the top
    start: float
    stop: float
    fill: str
    height: float  # of the row's height, centred on it
    edge: str | None = None
    label: str | None = None


@dataclass(frozen=True)
class Mark:
    time: float
    colour: str


@dataclass(frozen=True)
class Line:
    name: str
    points: tuple[tuple[float, float], ...]  # a step function, held after each point


@dataclass(frozen=True)
class Timeline:
    title: str
    origin: float  # the recording time that 0 stands for
    end: float  # seconds after origin
    rows: tuple[str, ...]
    bars: tuple[Bar, ...]
    marks: tuple[Mark, ...]
    lines: tuple[Line, ...]

    @property
    def axis_label(self) -> str:
        return f"seconds after {self.origin:.3f} on the recording's clock"


def layout(spec: ir.Spec, records: Sequence[Record]) -> Timeline:
    """The timeline of a replay's records (times counted from its first record)."""
    origin: Any = min((_when(r) for r in records if "time" in r or "from" in r), default=0)
    records = [_shifted(r, origin) for r in records]
    booleans = [e.name for e in spec.events if e.kind == "boolean"]
    rows = (
        *(p.name for p in spec.properties), *(t.name for t in spec.transducers), *booleans,
    )  # fmt: skip
    row = {name: i for i, name in enumerate(rows)}
    timed = [r for r in records if r["kind"] in ("verdict", "state", "event", "variable")]
    end = max((float(r["to"] if "to" in r else r["time"]) for r in timed), default=1.0)
    end = end if end > 0 else 1.0
    bars = [
        *_verdicts(records, row, end), *_states(records, row, end),
        *_booleans(records, row, set(booleans), end),
    ]  # fmt: skip
    title = (
        f"{spec.system.name}: verdicts (green true, red false, grey unknown), states, "
        "events; alert level changes orange, intrusions purple"
    )
    return Timeline(
        title, float(origin), end, rows, tuple(bars), tuple(_marks(records)),
        tuple(_lines(records, set(booleans))),
    )  # fmt: skip


def _verdicts(records: Sequence[Record], row: dict[str, int], end: float) -> list[Bar]:
    return [
        Bar(row[r["property"]], float(r["from"]),
            max(float(r["to"]), float(r["from"]) + end * 1e-4), VERDICT_COLOURS[r["verdict"]], 0.8)
        for r in records if r["kind"] == "verdict" and r["property"] in row
    ]  # fmt: skip


def _states(records: Sequence[Record], row: dict[str, int], end: float) -> list[Bar]:
    """Each transducer's states as labelled bars, each until the next change."""
    by_owner: dict[str, list[Record]] = {}
    for r in records:
        if r["kind"] == "state" and r["transducer"] in row:
            by_owner.setdefault(r["transducer"], []).append(r)
    bars = []
    for owner, changes in by_owner.items():
        for i, r in enumerate(changes):
            stop = float(changes[i + 1]["time"]) if i + 1 < len(changes) else end
            bars.append(Bar(row[owner], float(r["time"]), stop, STATE_FILL, 0.8, STATE_EDGE,
                            str(r["state"])))  # fmt: skip
    return bars


def _booleans(records: Sequence[Record], row: dict[str, int], names: set[str],
              end: float) -> list[Bar]:  # fmt: skip
    """Each boolean event's true stretches."""
    since: dict[str, float] = {}
    bars = []
    for r in records:
        if r["kind"] != "event" or r["name"] not in names:
            continue
        if r["value"] is True:
            since.setdefault(r["name"], float(r["time"]))
        elif r["name"] in since:
            start = since.pop(r["name"])
            bars.append(Bar(row[r["name"]], start, max(float(r["time"]), start + end * 1e-4),
                            EVENT_FILL, 0.6))  # fmt: skip
    bars += [Bar(row[name], start, end, EVENT_FILL, 0.6) for name, start in since.items()]
    return bars


def _marks(records: Sequence[Record]) -> list[Mark]:
    """An alert where its level changes (not at every point at a level); an
    intrusion where it starts."""
    marks = []
    for r in records:
        if r["kind"] == "alert" and r["level"] != r["previous"]:
            marks.append(Mark(float(r["time"]), ALERT_MARK))
        elif r["kind"] == "intrusion" and r["phase"] == "start":
            marks.append(Mark(float(r["time"]), INTRUSION_MARK))
    return marks


def _lines(records: Sequence[Record], booleans: set[str]) -> list[Line]:
    series: dict[str, list[tuple[float, float]]] = {}
    for r in records:
        # NaN and infinities are gaps in a line: no painter can place them.
        if r["kind"] in ("variable", "event") and _numeric(r["value"]) and isfinite(r["value"]):
            series.setdefault(r["name"], []).append((float(r["time"]), float(r["value"])))
    names = [name for name in series if name not in booleans][:MOST_LINES]
    return [Line(name, tuple(series[name])) for name in names]


def _when(record: Record) -> Any:
    return record["from"] if "from" in record else record["time"]


def _shifted(record: Record, origin: Any) -> Record:
    """The record with its times counted from the start of the replay."""
    out = dict(record)
    for key in ("time", "from", "to"):
        if key in out:
            out[key] = out[key] - origin
    return out


def _numeric(value: Any) -> bool:
    if isinstance(value, bool | str):
        return False
    return isinstance(value, int | float) or hasattr(value, "denominator")
