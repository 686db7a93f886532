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
long the trace. A JSON Lines chunk is decoded at once by msgspec (keys in any order,
fields other than these four ignored, the first one noted), each time kept as
written and read as a float besides: the floats check the order (no two decimals
come out of order as floats, ties go to the exact reader), the text gives the exact
time where the state changes; a CSV chunk is split at its newlines and commas
(rmvdsl.logic.trace_csv), its columns in any order (both: rmvdsl.logic.trace_runs).
A time `exact` would refuse (too many digits, a magnitude out of range) is never
taken fast. Any chunk that does not decode so, and any line that is not a plain
sample after the one before, goes through the full reader, which reports each
problem. Times come out exact, as whole billionths of the trace's unit (an int; a
Fraction only for a time finer than that).
"""

from __future__ import annotations

import codecs
import json
from collections.abc import Iterator
from fractions import Fraction
from typing import BinaryIO

from rmvdsl.grammar.formula import TIME_UNITS
from rmvdsl.logic.trace_chunks import ChunkDecoder, StateKey
from rmvdsl.logic.trace_csv import CsvRows
from rmvdsl.logic.trace_lines import LineReader, TraceError, is_csv, load_json
from rmvdsl.logic.trace_runs import Change, LineRuns

__all__ = ["CHUNK", "Change", "TraceError", "TraceStream"]

CHUNK = 1 << 20  # bytes read at a time


class TraceStream(LineRuns):
    """A trace file read as it is used. The unit is known on opening; `changes()`
    gives the first sample and every sample whose state differs from the one before,
    times in billionths of the unit. After it: `end` (the end record, else the last
    sample), `first`, `samples` (how many), `seen` (every proposition that held) and
    `notes`."""

    def __init__(self, path: str, handle: BinaryIO) -> None:
        self.path, self._handle = path, handle
        self._decoder = codecs.getincrementaldecoder("utf-8-sig")()
        self._newlines = 0  # in the bytes decoded so far
        self._read_newlines = 0  # in the last of them
        self._tail = 0  # bytes after the last of them
        self._head = self._read()
        self._csv = is_csv(path, self._head)
        self._reader = LineReader(path)
        self.end: Fraction | None = None
        self.first: Fraction | None = None
        self.samples = 0
        self.seen: set[str] = set()
        self.notes: list[str] = []
        self._states: dict[StateKey, frozenset[str]] = {}  # of the common lines
        self._current: frozenset[str] | None = None  # the state of the last sample
        self._chunks = ChunkDecoder(self._reader)
        self._rows_header: list[str] | None = None  # the CSV header `_rows` reads
        self._rows: CsvRows | None = None
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

    def changes(self) -> Iterator[Change]:
        # the newlines of a chunk are those of the text read last (`_read` counts
        # them): what stays over from a chunk has none
        number, chunk, newlines = 0, self._head, self._head.count("\n")
        while chunk:
            complete = chunk.rfind("\n") + 1
            if complete == 0:  # no whole line yet: read on, or this is the last line
                more = self._read()
                if more:
                    chunk += more
                    newlines = self._read_newlines
                    continue
                complete = len(chunk)
            lines, rest = chunk[:complete], chunk[complete:]
            count = newlines + (not lines.endswith("\n"))
            yield from self._chunk(lines, count, number)
            number += count
            chunk = rest + self._read()
            newlines = self._read_newlines
        for state in self._states.values():
            self.seen.update(state)
        self._finish()

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
        self._read_newlines = newlines
        self._tail = len(data) - data.rfind(b"\n") - 1 if newlines else self._tail + len(data)
        return text

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
        self.notes.extend(reader.ignored_note())
        if self.end is None:
            self.end = reader.last
            self.notes.append(
                f"{self.path}: no end record: the trace is known up to its last sample"
            )
