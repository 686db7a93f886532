"""One line of a trace file at a time, JSONL or CSV, each problem a TraceError with its
line and column: the reader that whole trace files and streams share; and the whole-file reader."""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from fractions import Fraction
from typing import TypeGuard

from rmvdsl.grammar.formula import TIME_UNITS
from rmvdsl.lang.numbers import NumberError, exact_or_quotient
from rmvdsl.runtime.wording import counted

NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_^{}]*")  # a proposition (fullmatch)
FIELDS = frozenset({"t", "state", "props", "end"})  # of a JSON Lines record


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


def is_csv(path: str, text: str) -> bool:
    stripped = text.lstrip()
    return path.endswith(".csv") or bool(stripped and not stripped.startswith("{"))


def read_trace(path: str, text: str) -> TraceFile:
    """A whole trace, every sample kept (the reference evaluator wants them all)."""
    reader, csv_file = LineReader(path), is_csv(path, text)
    read_line = reader.csv if csv_file else reader.jsonl
    for number, raw in enumerate(text.split("\n"), 1):
        read_line(number, raw)
    if csv_file and reader.header is None:
        raise TraceError(path, 1, 1, "the CSV file has no header", "start with `t,state`")
    trace = TraceFile(unit=reader.unit, end=reader.end, notes=reader.ignored_note())
    trace.times = [t for t, _ in reader.accepted]
    trace.states = [state for _, state in reader.accepted]
    if not trace.times:
        raise TraceError(
            path, 1, 1, "the trace has no samples", 'add lines such as {"t": 0, "state": "A"}'
        )
    if trace.end is None:
        trace.end = trace.times[-1]
        trace.notes.append(f"{path}: no end record: the trace is known up to its last sample")
    return trace


class TraceError(Exception):
    def __init__(self, path: str, line: int, column: int, message: str, help: str | None = None):
        super().__init__(message)
        self.path, self.line, self.column, self.help = path, line, column, help

    def __str__(self) -> str:
        where = f"{self.path}:{self.line}:{self.column}"
        text = f"{where}: {self.args[0]}"
        return text + (f" (help: {self.help})" if self.help else "")


class LineReader:
    """The checks every line passes, and what they leave: the unit, the last sample
    (its time kept as text until an exact comparison needs it), the end."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.unit = "s"
        self.end: Fraction | None = None
        self.last_text: str | None = None  # the newest sample's time as written
        self.last_float = float("-inf")
        self._last: Fraction | None = None
        self.accepted: list[tuple[Fraction, frozenset[str]]] = []  # by the full reader
        self.header: list[str] | None = None  # CSV
        self.ignored: tuple[str, int] | None = None  # the first field ignored, and its line

    def ignore(self, name: str, line: int) -> None:
        """A field the trace does not use (a logger's sequence number, say)."""
        if self.ignored is None:
            self.ignored = (name, line)

    def ignored_note(self) -> list[str]:
        if self.ignored is None:
            return []
        name, line = self.ignored
        return [f"{self.path}:{line}: fields other than t, state, props and end are ignored "
                f"(the first: `{name}`)"]  # fmt: skip

    @property
    def last(self) -> Fraction | None:
        if self._last is None and self.last_text is not None:
            self._last = exact_or_quotient(self.last_text)
        return self._last

    def add(
        self,
        line: int,
        column: int,
        t: Fraction,
        state: frozenset[str],
        names_at: int | None = None,
    ) -> None:
        """A sample at `t` (written at `column`; its names at `names_at`, default the
        same)."""
        if self.end is not None:
            raise TraceError(
                self.path, line, 1, "a sample after the end record", "the end record comes last"
            )
        last = self.last
        if last is not None and t <= last:
            what = "goes backwards" if t < last else "does not advance"
            raise TraceError(
                self.path,
                line,
                column,
                f"time {t} {what} (the previous sample is at {last})",
                "samples must be in strictly increasing time",
            )
        for name in state:
            if not NAME.fullmatch(name):
                raise TraceError(self.path, line, column if names_at is None else names_at,
                                 f"`{name}` is not a proposition name")  # fmt: skip
        self._last, self.last_text, self.last_float = t, None, float(t)
        self.accepted.append((t, state))

    def close(self, line: int, column: int, t: Fraction) -> None:
        if self.end is not None:
            raise TraceError(self.path, line, 1, "a second end record")
        last = self.last
        if last is not None and t < last:
            raise TraceError(
                self.path, line, column, f"the end {t} is before the last sample ({last})"
            )
        self.end = t

    def set_unit(self, unit: str, line: int, column: int) -> None:
        if self.last_text is not None or self._last is not None:
            raise TraceError(self.path, line, column, "the unit comes before the first sample")
        unit = {"u": "us"}.get(unit, unit)
        if unit not in TIME_UNITS:
            raise TraceError(
                self.path, line, column, f"unknown unit `{unit}`", "ns, us, ms, s, m, h, d or w"
            )
        self.unit = unit

    def fast_order(self, text: str, line: int, raw: str) -> None:
        """A fast line whose time is not above the last as a float: compare exactly."""
        t = exact_or_quotient(text)
        last = self.last
        if last is not None and t <= last:
            self.jsonl(line, raw) if self.header is None else self.csv(line, raw)  # raises
        self._last = t

    # ---- the full reader, one line at a time ----

    def jsonl(self, number: int, raw: str) -> None:
        raw = raw.rstrip("\r")
        if not raw.strip():
            return
        try:
            record = load_json(raw)
        except json.JSONDecodeError as exc:
            raise TraceError(self.path, number, exc.colno, f"not JSON: {exc.msg}") from None
        if not isinstance(record, dict):
            raise TraceError(self.path, number, 1, "each line must be a JSON object")
        column = _columns(raw)
        if set(record) == {"unit"}:
            self.set_unit(str(record["unit"]), number, column("unit"))
            return
        unknown = [key for key in record if key not in FIELDS]  # in the order written
        if unknown and not ({"state", "props", "end"} & set(record)):  # a misspelt field
            raise TraceError(self.path, number, column(unknown[0]), f"unknown field `{unknown[0]}`",
                             'a sample has "state" or "props"; others are ignored')  # fmt: skip
        if unknown:
            self.ignore(unknown[0], number)
        if "t" not in record:
            raise TraceError(self.path, number, 1, 'a record without "t"')
        t = _time(record["t"], self.path, number, column("t"))
        if record.get("end") is True:
            if "state" in record or "props" in record:
                raise TraceError(self.path, number, column("end"), "an end record has no state")
            self.close(number, column("t"), t)
            return
        if "end" in record:
            raise TraceError(self.path, number, column("end"), '"end" must be true')
        names_at = column("state" if "state" in record else "props")
        self.add(number, column("t"), t, _state(record, self.path, number, column), names_at)

    def csv(self, number: int, raw: str) -> None:
        raw = raw.rstrip("\r")
        if self.header is None:
            self._csv_preamble(number, raw)
            return
        if not raw.strip():
            return
        row = _csv_row(raw, self.path, number)
        header = self.header
        if len(row) != len(header):
            raise TraceError(
                self.path,
                number,
                1,
                f"{counted(len(row), 'cell')} for {counted(len(header), 'column')}",
            )
        cells = dict(zip(header, (c.strip() for c in row), strict=True))
        t = _time(cells["t"], self.path, number, 1)
        if cells.get("end", "").lower() in ("true", "1", "yes"):
            self.close(number, 1, t)
            return
        named_by = "state" if "state" in header else "props"
        self.add(number, 1, t, csv_state(cells[named_by], named_by == "props"))

    def _csv_preamble(self, number: int, raw: str) -> None:
        """Comments (`# unit: ms`) and blank lines, then the header."""
        if not raw.strip() or raw.lstrip().startswith("#"):
            match = re.match(r"^\s*#\s*unit\s*:\s*(\S+)\s*$", raw)
            if match:
                self.set_unit(match.group(1), number, raw.find(match.group(1)) + 1)
            return
        header = [h.strip() for h in _csv_row(raw, self.path, number)]
        if "t" not in header or not ({"state", "props"} & set(header)):
            raise TraceError(
                self.path,
                number,
                1,
                f"the header `{','.join(header)}` has no `t` and `state` (or `props`) columns",
            )
        unknown = [h for h in header if h not in {"t", "state", "props", "end"}]
        if unknown:
            raise TraceError(self.path, number, 1, f"unknown column `{unknown[0]}`")
        self.header = header


def _csv_row(raw: str, path: str, number: int) -> list[str]:
    """One line's cells; a line the csv module refuses is the trace's error."""
    try:
        return next(csv.reader([raw]), [])
    except csv.Error as error:
        text = str(error)
        why = ("a line break inside a cell" if "new-line" in text
               else "a NUL character" if "NUL" in text else text)  # fmt: skip
        raise TraceError(path, number, 1, f"not a CSV row: {why}") from None


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


def _columns(raw: str) -> Callable[[str], int]:
    """Where a key stands on its line (1 when it does not)."""

    def column(key: str) -> int:
        return raw.find(f'"{key}"') + 1 or 1

    return column


def csv_state(cell: str, props: bool) -> frozenset[str]:
    """The propositions a CSV cell names: a `props` cell's, separated by `;`, or a
    `state` cell's one (none where it is empty)."""
    if props:
        return frozenset(name.strip() for name in cell.split(";") if name.strip())
    return frozenset((cell,)) if cell else frozenset()


def _state(
    record: dict[str, object], path: str, line: int, column: Callable[[str], int]
) -> frozenset[str]:
    if ("state" in record) == ("props" in record):
        raise TraceError(path, line, 1, 'a sample has either "state" or "props"')
    # A number is read as its text (`JsonNumber`, a str): `"state": NaN` is not the
    # proposition `NaN`.
    if "state" in record:
        value = record["state"]
        if not _text(value):
            raise TraceError(path, line, column("state"), '"state" is a string')
        return frozenset({value})
    value = record["props"]
    if not isinstance(value, list) or not all(_text(v) for v in value):
        raise TraceError(path, line, column("props"), '"props" is a list of strings')
    return frozenset(value)


def _text(value: object) -> TypeGuard[str]:
    """A JSON string (not a number, which the reader keeps as its text)."""
    return isinstance(value, str) and not isinstance(value, JsonNumber)
