"""Trace files for `rmv eval`: JSON Lines or CSV of state changes.

JSONL, one object per line:

    {"unit": "ms"}                      optional first line; default seconds
    {"t": 0, "state": "Cruising"}       one proposition holds from t on
    {"t": 1.5, "props": ["a", "b"]}     several (or none: [])
    {"t": 12.0, "end": true}            the trace ends: known up to 12

A time is a number, or a string holding one or an exact fraction ("1/3", as
`rmv sat` writes a witness time that no decimal gives exactly).

CSV, with a header naming `t` and `state` or `props` (propositions separated by
`;`), and optionally `end` (a row with `end` true ends the trace). A first line
`# unit: ms` sets the unit. Without an end record the trace ends at its last
sample. Every problem is reported with its line (and column where it helps).
"""

from __future__ import annotations

import csv
import io
import json
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from fractions import Fraction

from rmvdsl.grammar.formula import TIME_UNITS
from rmvdsl.numbers import NumberError, exact_or_quotient

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_^{}]*$")


class TraceError(Exception):
    def __init__(self, path: str, line: int, column: int, message: str, help: str | None = None):
        super().__init__(message)
        self.path, self.line, self.column, self.help = path, line, column, help

    def __str__(self) -> str:
        where = f"{self.path}:{self.line}:{self.column}"
        text = f"{where}: {self.args[0]}"
        return text + (f" (help: {self.help})" if self.help else "")


@dataclass
class TraceFile:
    times: list[Fraction] = field(default_factory=list)
    states: list[frozenset[str]] = field(default_factory=list)
    end: Fraction | None = None
    unit: str = "s"
    notes: list[str] = field(default_factory=list)

    @property
    def unit_seconds(self) -> Fraction:
        return TIME_UNITS[self.unit]


def read_trace(path: str, text: str) -> TraceFile:
    stripped = text.lstrip()
    if path.endswith(".csv") or (stripped and not stripped.startswith("{")):
        trace = _read_csv(path, text)
    else:
        trace = _read_jsonl(path, text)
    if not trace.times:
        raise TraceError(
            path, 1, 1, "the trace has no samples", 'add lines such as {"t": 0, "state": "A"}'
        )
    if trace.end is None:
        trace.end = trace.times[-1]
        trace.notes.append(f"{path}: no end record: the trace is known up to its last sample")
    return trace


class JsonNumber(str):
    """A number of a JSON text as written: read exactly, never through a float."""


def load_json(raw: str) -> object:
    """JSON with its numbers kept as written (`JsonNumber`); NaN and Infinity too."""
    return json.loads(raw, parse_float=JsonNumber, parse_int=JsonNumber,
                      parse_constant=JsonNumber)  # fmt: skip


def _time(value: object, path: str, line: int, column: int) -> Fraction:
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise TraceError(path, line, column, f"`t` must be a number, not {json.dumps(value)}")
    text = str(value).strip()
    try:
        return exact_or_quotient(text)  # "1/3": an exact fraction, as `rmv sat` writes
    except NumberError as exc:
        message = f"`t` must be a number: {exc}"
        if text.lower().lstrip("+-") in ("nan", "infinity", "inf"):
            message = f"`t` is {text}: times must be finite numbers"
        raise TraceError(path, line, column, message) from None


def _add(
    trace: TraceFile, path: str, line: int, column: int, t: Fraction, state: frozenset[str]
) -> None:
    if trace.end is not None:
        raise TraceError(
            path, line, 1, "a sample after the end record", "the end record comes last"
        )
    if trace.times and t <= trace.times[-1]:
        what = "goes backwards" if t < trace.times[-1] else "does not advance"
        raise TraceError(
            path,
            line,
            column,
            f"time {t} {what} (the previous sample is at {trace.times[-1]})",
            "samples must be in strictly increasing time",
        )
    for name in state:
        if not _NAME.match(name):
            raise TraceError(path, line, column, f"`{name}` is not a proposition name")
    trace.times.append(t)
    trace.states.append(state)


def _end(trace: TraceFile, path: str, line: int, column: int, t: Fraction) -> None:
    if trace.end is not None:
        raise TraceError(path, line, 1, "a second end record")
    if trace.times and t < trace.times[-1]:
        raise TraceError(
            path, line, column, f"the end {t} is before the last sample ({trace.times[-1]})"
        )
    trace.end = t


def _read_jsonl(path: str, text: str) -> TraceFile:
    trace = TraceFile()
    for number, raw in enumerate(text.splitlines(), 1):
        if not raw.strip():
            continue
        try:
            record = load_json(raw)
        except json.JSONDecodeError as exc:
            raise TraceError(path, number, exc.colno, f"not JSON: {exc.msg}") from None
        if not isinstance(record, dict):
            raise TraceError(path, number, 1, "each line must be a JSON object")
        column = _columns(raw)
        if set(record) == {"unit"}:
            _unit(trace, str(record["unit"]), path, number, column("unit"))
            continue
        unknown = sorted(set(record) - {"t", "state", "props", "end"})
        if unknown:
            raise TraceError(path, number, column(unknown[0]), f"unknown field `{unknown[0]}`",
                             'fields are "t", "state", "props" and "end"')  # fmt: skip
        if "t" not in record:
            raise TraceError(path, number, 1, 'a record without "t"')
        t = _time(record["t"], path, number, column("t"))
        if record.get("end") is True:
            if "state" in record or "props" in record:
                raise TraceError(path, number, column("end"), "an end record has no state")
            _end(trace, path, number, column("t"), t)
            continue
        if "end" in record:
            raise TraceError(path, number, column("end"), '"end" must be true')
        trace_state = _state(record, path, number, column)
        _add(trace, path, number, column("t"), t, trace_state)
    return trace


def _columns(raw: str) -> Callable[[str], int]:
    """Where a key stands on its line (1 when it does not)."""

    def column(key: str) -> int:
        return raw.find(f'"{key}"') + 1 or 1

    return column


def _state(
    record: dict[str, object], path: str, line: int, column: Callable[[str], int]
) -> frozenset[str]:
    if ("state" in record) == ("props" in record):
        raise TraceError(path, line, 1, 'a sample has either "state" or "props"')
    if "state" in record:
        value = record["state"]
        if not isinstance(value, str):
            raise TraceError(path, line, column("state"), '"state" is a string')
        return frozenset({value})
    value = record["props"]
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise TraceError(path, line, column("props"), '"props" is a list of strings')
    return frozenset(value)


def _unit(trace: TraceFile, unit: str, path: str, line: int, column: int) -> None:
    if trace.times:
        raise TraceError(path, line, column, "the unit comes before the first sample")
    unit = {"u": "us"}.get(unit, unit)
    if unit not in TIME_UNITS:
        raise TraceError(
            path, line, column, f"unknown unit `{unit}`", "ns, us, ms, s, m, h, d or w"
        )
    trace.unit = unit


def _read_csv(path: str, text: str) -> TraceFile:
    trace = TraceFile()
    lines = text.splitlines()
    first = 0
    while first < len(lines) and (
        not lines[first].strip() or lines[first].lstrip().startswith("#")
    ):
        match = re.match(r"^\s*#\s*unit\s*:\s*(\S+)\s*$", lines[first])
        if match:
            _unit(trace, match.group(1), path, first + 1, lines[first].find(match.group(1)) + 1)
        first += 1
    reader = csv.reader(io.StringIO("\n".join(lines[first:])))
    try:
        header = [h.strip() for h in next(reader)]
    except StopIteration:
        raise TraceError(path, 1, 1, "the CSV file has no header", "start with `t,state`") from None
    if "t" not in header or not ({"state", "props"} & set(header)):
        raise TraceError(
            path,
            first + 1,
            1,
            f"the header `{','.join(header)}` has no `t` and `state` (or `props`) columns",
        )
    unknown = [h for h in header if h not in {"t", "state", "props", "end"}]
    if unknown:
        raise TraceError(path, first + 1, 1, f"unknown column `{unknown[0]}`")
    state_column = "state" if "state" in header else "props"
    for offset, row in enumerate(reader):
        number = first + 2 + offset
        if not row or not any(cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise TraceError(path, number, 1, f"{len(row)} cells for {len(header)} columns")
        cells = dict(zip(header, (c.strip() for c in row), strict=True))
        t = _time(cells["t"], path, number, 1)
        if cells.get("end", "").lower() in ("true", "1", "yes"):
            _end(trace, path, number, 1, t)
            continue
        raw = cells[state_column]
        if state_column == "state":
            state = frozenset({raw}) if raw else frozenset()
        else:
            state = frozenset(p.strip() for p in raw.split(";") if p.strip())
        _add(trace, path, number, 1, t, state)
    return trace
