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

`TraceStream` reads a file as it is used: its unit at once, then its state changes
one chunk of lines at a time, so that `rmv eval` holds no more than a chunk however
long the trace. Lines of the common shape (`{"t": 1.25, "state": "A"}`, or CSV
`1.25,A` under a `t,state` header) are read by one regular expression per chunk and
their times compared as floats (exactly where two floats tie); every other line goes
through the full reader, which reports each problem. Times come out exact, as whole
billionths of the trace's unit (an int; a Fraction only for a time finer than that).
"""

from __future__ import annotations

import codecs
import json
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from fractions import Fraction
from typing import BinaryIO

from rmvdsl.grammar.formula import TIME_UNITS
from rmvdsl.lang.numbers import exact_or_quotient
from rmvdsl.logic.trace_lines import LineReader, TraceError, load_json


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


SCALE = 10**9  # a stream's times: whole billionths of the trace's unit
CHUNK = 1 << 20  # bytes read at a time
_DECIMAL = r"(-?(?:0|[1-9][0-9]{0,14})(?:\.[0-9]{1,9})?)"  # exact in billionths, in range
_PROPOSITION = r"([A-Za-z_][A-Za-z0-9_]*)"
_FAST_JSONL = re.compile(
    rf'^[ \t]*\{{[ \t]*"t"[ \t]*:[ \t]*{_DECIMAL}[ \t]*,[ \t]*"state"[ \t]*:[ \t]*'
    rf'"{_PROPOSITION}"[ \t]*\}}[ \t\r]*$',
    re.MULTILINE,
)
_FAST_CSV = re.compile(rf"^[ \t]*{_DECIMAL}[ \t]*,[ \t]*{_PROPOSITION}[ \t\r]*$", re.MULTILINE)
_NAME_TEXT = re.compile(_PROPOSITION)


StateKey = str | frozenset[str]  # one proposition's name, or the set a `props` line names
# The text of a line's time, where a JSON key "t" is followed by a decimal (a name
# cannot hold a quote, so a value that passes the checks holds no such text).
_TIME_TEXT = re.compile(rf'"t"[ \t]*:[ \t]*{_DECIMAL}[ \t]*[,}}]')


def common_sample(raw: str) -> tuple[str, StateKey] | None:
    """A JSON line with the common content in any key order or spacing: `t` a
    decimal number and `state` a name, or `props` a list of names; its time's text
    and its state. None: the full reader decides (and explains) the line."""
    try:
        record = json.loads(raw)
    except ValueError:
        return None
    if type(record) is not dict or len(record) != 2 or type(record.get("t")) not in (int, float):
        return None
    state = record.get("state")
    if type(state) is str and _NAME_TEXT.fullmatch(state):
        key: StateKey = state
    else:
        names = record.get("props")
        if type(names) is not list or not all(
            type(n) is str and _NAME_TEXT.fullmatch(n) for n in names
        ):
            return None
        key = frozenset(names)
    found = _TIME_TEXT.search(raw)
    return None if found is None else (found[1], key)


def scaled(t: Fraction) -> int | Fraction:
    """A time in billionths of its unit: an int where that is exact."""
    value = t * SCALE
    return value.numerator if value.denominator == 1 else value


def _decimal_scaled(text: str) -> int:
    """A decimal the fast reader matched (at most 9 decimals) in billionths."""
    whole, _, fraction = text.partition(".")
    return int(whole + fraction.ljust(9, "0"))


def _is_csv(path: str, text: str) -> bool:
    stripped = text.lstrip()
    return path.endswith(".csv") or bool(stripped and not stripped.startswith("{"))


def read_trace(path: str, text: str) -> TraceFile:
    """A whole trace, every sample kept (the reference evaluator wants them all)."""
    reader, is_csv = LineReader(path), _is_csv(path, text)
    read_line = reader.csv if is_csv else reader.jsonl
    for number, raw in enumerate(text.split("\n"), 1):
        read_line(number, raw)
    if is_csv and reader.header is None:
        raise TraceError(path, 1, 1, "the CSV file has no header", "start with `t,state`")
    trace = TraceFile(unit=reader.unit, end=reader.end)
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


class TraceStream:
    """A trace file read as it is used. The unit is known on opening; `changes()`
    gives the first sample and every sample whose state differs from the one before,
    times in billionths of the unit. After it: `end` (the end record, else the last
    sample), `first`, `samples` (how many), `seen` (every proposition that held) and
    `notes`."""

    def __init__(self, path: str, handle: BinaryIO) -> None:
        self.path, self._handle = path, handle
        self._decoder = codecs.getincrementaldecoder("utf-8-sig")()
        self._newlines = 0  # in the bytes decoded so far
        self._tail = 0  # bytes after the last of them
        self._head = self._read()
        self._csv = _is_csv(path, self._head)
        self._reader = LineReader(path)
        self.end: Fraction | None = None
        self.first: Fraction | None = None
        self.samples = 0
        self.seen: set[str] = set()
        self.notes: list[str] = []
        self._states: dict[StateKey, frozenset[str]] = {}  # of the common lines
        self._current: frozenset[str] | None = None  # the state of the last sample
        self._peek_unit()

    @property
    def unit(self) -> str:
        return self._reader.unit

    @property
    def unit_seconds(self) -> Fraction:
        return TIME_UNITS[self.unit]

    def _peek_unit(self) -> None:
        """The unit comes first: read it (checked) before any sample, reading on
        while the lines so far are all blank, comments or unit records."""
        peek = LineReader(self.path)
        number = 0
        while True:
            lines = self._head.split("\n")
            for raw in lines[number:-1]:
                number += 1
                if not self._leading(raw):
                    self._reader.unit = peek.unit
                    return
                (peek.csv if self._csv else peek.jsonl)(number, raw)
            more = self._read()
            if not more:
                self._reader.unit = peek.unit
                return
            self._head += more

    def _leading(self, raw: str) -> bool:
        """A line that may stand before the first sample and set the unit."""
        if not raw.strip():
            return True
        if self._csv:
            return raw.lstrip().startswith("#")
        try:
            record = load_json(raw)
        except json.JSONDecodeError:
            return False
        return isinstance(record, dict) and set(record) == {"unit"}

    def changes(self) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        fast = _FAST_CSV if self._csv else _FAST_JSONL
        number, chunk = 0, self._head
        while chunk:
            complete = chunk.rfind("\n") + 1
            if complete == 0:  # no whole line yet: read on, or this is the last line
                more = self._read()
                if more:
                    chunk += more
                    continue
                complete = len(chunk)
            lines, rest = chunk[:complete], chunk[complete:]
            count = lines.count("\n") + (not lines.endswith("\n"))
            pairs = fast.findall(lines) if self._fast_ready() else []
            if len(pairs) == count:  # every line of the common shape
                yield from self._fast_lines(pairs, number, lines)
                number += count
            else:
                raws = lines.split("\n")[:count]
                ready = self._fast_ready()
                found = [self._common(fast, raw) if ready else None for raw in raws]
                common = [pair for pair in found if pair is not None]
                if len(common) == count:  # every line of common content, in any form
                    yield from self._fast_lines(common, number, lines)
                    number += count
                    raws = []
                for raw in raws:
                    pair = self._common(fast, raw) if self._fast_ready() else None
                    if pair is not None:
                        yield from self._fast_lines([pair], number, raw)
                    else:
                        yield from self._full_line(number + 1, raw)
                    number += 1
            chunk = rest + self._read()
        for key in self._states:
            self.seen.update((key,) if type(key) is str else key)
        self._finish()

    def _common(self, fast: re.Pattern[str], raw: str) -> tuple[str, StateKey] | None:
        """The time's text and the state of a line of common content: the chunk's
        expression first, then (JSON Lines) any key order, spacing or `props` list,
        as fast as JSON's own parser reads them."""
        match = fast.match(raw)
        if match is not None:
            return match[1], match[2]
        return None if self._csv else common_sample(raw)

    def _fast_lines(
        self, pairs: list[tuple[str, StateKey]], before: int, lines: str
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """Lines of the common shape, the ones after line `before` (their text is
        `lines`, read again only to report a time out of order): the hot loop."""
        reader, states, current = self._reader, self._states, self._current
        for index, (text, name) in enumerate(pairs):
            value = float(text)
            if value <= reader.last_float:  # maybe out of order: compared exactly
                reader.fast_order(text, before + index + 1, lines.split("\n")[index])
            reader.last_float, reader.last_text = value, text
            reader._last = None
            state = states.get(name)
            if state is None:
                state = frozenset((name,)) if isinstance(name, str) else name
                states[name] = state
            if state is not current:
                if current is None:
                    self.first = exact_or_quotient(text)
                current = state
                yield _decimal_scaled(text), state
        self._current = current
        self.samples += len(pairs)

    def _full_line(self, number: int, raw: str) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """Any other line, through the full reader and its checks."""
        reader = self._reader
        (reader.csv if self._csv else reader.jsonl)(number, raw)
        for t, state in reader.accepted:
            self.samples += 1
            self.seen.update(state)
            if state != self._current:
                if self._current is None:
                    self.first = t
                self._current = state
                yield scaled(t), state
        reader.accepted.clear()

    def _read(self) -> str:
        """The next chunk, decoded; a byte that is not UTF-8 is reported where it is."""
        data = self._handle.read(CHUNK)
        try:
            text = self._decoder.decode(data, final=not data)
        except UnicodeDecodeError as exc:
            before = exc.object[: exc.start]
            line = self._newlines + before.count(b"\n") + 1
            start = before.rfind(b"\n") + 1
            column = exc.start - start + 1 + (self._tail if start == 0 else 0)
            byte = exc.object[exc.start]
            raise TraceError(
                self.path, line, column, f"not UTF-8 text (the byte 0x{byte:02x})"
            ) from None
        newlines = data.count(b"\n")
        self._newlines += newlines
        self._tail = len(data) - data.rfind(b"\n") - 1 if newlines else self._tail + len(data)
        return text

    def _fast_ready(self) -> bool:
        """Lines are read fast before the end record (after it, each is an error)
        and, in CSV, under a `t,state` header only."""
        reader = self._reader
        return reader.end is None and (not self._csv or reader.header == ["t", "state"])

    def _finish(self) -> None:
        reader = self._reader
        if self._csv and reader.header is None:
            raise TraceError(self.path, 1, 1, "the CSV file has no header", "start with `t,state`")
        if reader.last is None:
            raise TraceError(
                self.path,
                1,
                1,
                "the trace has no samples",
                'add lines such as {"t": 0, "state": "A"}',
            )
        self.end = reader.end
        if self.end is None:
            self.end = reader.last
            self.notes.append(
                f"{self.path}: no end record: the trace is known up to its last sample"
            )
