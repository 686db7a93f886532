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
(rmvdsl.logic.trace_csv), its columns in any order. A time `exact` would refuse
(too many digits, a magnitude out of range) is never taken fast. Any chunk that
does not decode so, and any line that is not a plain sample after the one before,
goes through the full reader, which reports each problem. Times come out exact, as whole
billionths of the trace's unit (an int; a Fraction only for a time finer than that).
"""

from __future__ import annotations

import codecs
import functools
import json
import operator
from collections.abc import Callable, Iterator
from fractions import Fraction
from itertools import compress, count, islice
from typing import Any, BinaryIO

from rmvdsl.grammar.formula import TIME_UNITS
from rmvdsl.lang.numbers import exact_or_quotient
from rmvdsl.logic.trace_chunks import (
    LARGEST,
    SMALLEST,
    ChunkDecoder,
    Decoded,
    Record,
    StateKey,
    propositions,
    readable,
    scaled,
    text_scaled,
    time_text,
)
from rmvdsl.logic.trace_csv import CsvRows, rows_of
from rmvdsl.logic.trace_lines import LineReader, TraceError, is_csv, load_json

CHUNK = 1 << 20  # bytes read at a time
Change = tuple[int | Fraction, frozenset[str]]  # a time in billionths, the state from it


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

    def changes(self) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
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

    def _chunk(
        self, lines: str, count: int, before: int
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """The lines after line `before`: decoded at once where they allow it, else
        one at a time by the full reader, which explains any problem."""
        if self._csv and self._reader.header is None:
            yield from self._csv_header(lines, count, before)
            return
        if self._fast_ready():
            if self._csv:
                rows = self._csv_rows()
                if rows is not None:
                    yield from self._csv_runs(rows, lines, count, before)
                    return
            else:
                yield from self._json_runs(lines, count, before)
                return
        yield from self._full_lines(lines, count, before)

    def _json_runs(
        self, lines: str, count: int, before: int
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """A JSON Lines chunk at once where it can be. Where its first records are
        plain samples and a later one is not (the end record ends every trace's
        last chunk), the lines before that one at once, the next by the full
        reader, and on with the rest, as `_csv_runs` does. The count of records
        before that one need not be one of lines (`{...}, {...}` on a line is two
        items of the chunk's array): a piece is read at once only where it
        decodes to one record a line, and by the full reader otherwise; each turn
        takes at least two lines."""
        decoded = self._chunks.decode(lines, count, before)
        while isinstance(decoded, int) and decoded < count:
            pieces = lines.split("\n", decoded + 1)
            first = "\n".join(pieces[:decoded]) + "\n"
            yield from self._decoded(
                self._chunks.decode(first, decoded, before), first, decoded, before
            )
            yield from self._full_line(before + decoded + 1, pieces[decoded])
            lines = pieces[decoded + 1] if len(pieces) > decoded + 1 else ""
            count, before = count - decoded - 1, before + decoded + 1
            if not count:
                return
            if not self._fast_ready():  # after the end record: each line is the full reader's
                yield from self._full_lines(lines, count, before)
                return
            decoded = self._chunks.decode(lines, count, before)
        yield from self._decoded(decoded, lines, count, before)

    def _decoded(
        self, decoded: Decoded | int | None, lines: str, count: int, before: int
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """Lines as `ChunkDecoder.decode` read them at once, or by the full reader
        where it did not."""
        if not isinstance(decoded, tuple):
            yield from self._full_lines(lines, count, before)
            return
        plain, records, times = decoded
        if plain:
            yield from self._fast_plain(plain, records, times, before, lines)
        else:
            yield from self._fast_records(records, times, before, lines)

    def _csv_header(
        self, lines: str, count: int, before: int
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """The lines up to the header (comments, the unit) and the header one at a
        time; the rest of the chunk as any other."""
        taken = 0
        for raw in lines.split("\n")[:count]:
            yield from self._full_line(before + taken + 1, raw)
            taken += 1
            if self._reader.header is not None:
                break
        if taken < count:
            offset = 0  # where the line after the header begins
            for _ in range(taken):
                offset = lines.index("\n", offset) + 1
            yield from self._chunk(lines[offset:], count - taken, before + taken)

    def _csv_runs(
        self, rows: CsvRows, lines: str, count: int, before: int
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """A CSV chunk a run of plain rows at a time (`CsvRows.plain_run`), each row
        between two runs by the full reader: an end row or a blank line no longer
        sends the rest of its chunk (up to 1 MB) to the full reader."""
        while count:
            taken, split = rows.plain_run(lines, count)
            if split is not None:
                texts, times, keys = split
                again = functools.partial(self._full_lines, lines, taken, before)
                yield from self._fast_runs(keys, times, texts.__getitem__, rows.state, again)
            if taken == count:
                return
            pieces = lines.split("\n", taken + 1)
            yield from self._full_line(before + taken + 1, pieces[taken])
            lines = pieces[taken + 1] if len(pieces) > taken + 1 else ""
            count, before = count - taken - 1, before + taken + 1
            if not self._fast_ready():  # after the end row: each line is the full reader's
                yield from self._full_lines(lines, count, before)
                return

    def _full_lines(
        self, lines: str, count: int, before: int
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        for index, raw in enumerate(lines.split("\n")[:count]):
            yield from self._full_line(before + index + 1, raw)

    def _fast_plain(
        self, named_by: str, records: list[Any], times: list[float], before: int, lines: str
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """Plain samples, each naming its state by the field `named_by` ("state" or
        "props"). Anything to explain (a time not above the last, a new name that is
        no proposition) is left to the record at a time path."""

        def general() -> Iterator[tuple[int | Fraction, frozenset[str]]]:
            decoded = self._chunks.records(lines)  # rare: decoded again
            if decoded is None:
                return self._full_lines(lines, len(records), before)
            return self._fast_records(*decoded, before, lines)

        keys = list(map(operator.attrgetter(named_by), records))
        yield from self._fast_runs(
            keys, times, lambda index: time_text(records[index]), propositions, general
        )

    def _fast_runs(
        self,
        keys: list[Any],
        times: list[float],
        text_at: Callable[[int], str],
        state_of: Callable[[Any], frozenset[str] | None],
        general: Callable[[], Iterator[tuple[int | Fraction, frozenset[str]]]],
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """A chunk of plain samples: each one's key (what names its state), its time
        as a float and as written (`text_at`). Checked by the interpreter's own loops
        over the times and keys (the hottest path: most chunks of most traces), a
        sample looked at on its own only where its key differs from the one before.
        Where the floats are not in increasing order (a tie, or a time not above the
        last) or a new key's names are no propositions (`state_of` gives None), the
        chunk goes to `general`, which explains it."""
        starts = [0, *compress(count(1), map(operator.ne, islice(keys, 1, None), keys))]
        states, reader = self._states, self._reader
        new = {key: state_of(key) for key in {keys[index] for index in starts} if key not in states}
        if (
            times[0] <= reader.last_float
            or not all(map(operator.lt, times, islice(times, 1, None)))
            or None in new.values()
            or not readable(times, text_at)
        ):
            yield from general()
            return
        states.update(new)  # (no None: checked above)
        current = self._current
        for index in starts:
            state = states[keys[index]]
            if state is not current and state != current:
                text = text_at(index)
                if current is None:
                    self.first = exact_or_quotient(text)
                current = state
                yield text_scaled(text), state
        self._current = current
        self._settle(times[-1], text_at(len(times) - 1), len(times))

    def _fast_records(
        self, records: list[Any], times: list[float], before: int, lines: str
    ) -> Iterator[tuple[int | Fraction, frozenset[str]]]:
        """Decoded records, the ones after line `before`: the hot loop. A record that
        is not a plain sample after the one before (a new name, a time not above the
        last, the end record) goes to the full reader."""
        reader, states, current = self._reader, self._states, self._current
        last, newest, taken, raws = reader.last_float, None, 0, None
        for index, (record, value) in enumerate(zip(records, times, strict=True)):
            state = None
            if value > last and reader.end is None and SMALLEST < abs(value) < LARGEST:
                if record.end is None and record.unit is None:
                    props = record.props
                    state = states.get(record.state if props is None else props)
                    if record.state is not None and props is not None:
                        state = None  # both: the full reader says which to keep
                if state is None:
                    state = self._new_state(record)
            if state is None:
                self._settle(last, newest and time_text(newest), taken)
                raws = raws or lines.split("\n")
                self._current = current
                yield from self._full_line(before + index + 1, raws[index])
                current, last, taken = self._current, reader.last_float, 0
                continue
            last, newest = value, record
            taken += 1
            if state is not current and state != current:
                text = time_text(record)
                if current is None:
                    self.first = exact_or_quotient(text)
                current = state
                yield text_scaled(text), state
        self._settle(last, newest and time_text(newest), taken)
        self._current = current

    def _new_state(self, record: Record) -> frozenset[str] | None:
        """The state of a plain sample naming a state not seen before, if its names
        are propositions' (else the full reader reports them)."""
        if record.end is not None or record.unit is not None:
            return None
        key: StateKey | None = record.state if record.props is None else record.props
        if key is None or (record.state is not None and record.props is not None):
            return None  # neither, or both: the full reader says which to keep
        state = propositions(key)
        if state is not None:
            self._states[key] = state
        return state

    def _settle(self, last: float, text: str | None, taken: int) -> None:
        """The reader learns the newest of `taken` samples read fast: its time as a
        float and as written."""
        if taken:
            reader = self._reader
            reader.last_float, reader.last_text, reader._last = last, text, None
            self.samples += taken

    def _csv_rows(self) -> CsvRows | None:
        """The fast reading of the CSV header's rows, built once per header."""
        header = self._reader.header
        if header is not self._rows_header:
            self._rows_header, self._rows = header, rows_of(header) if header else None
        return self._rows

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
        self._read_newlines = newlines
        self._tail = len(data) - data.rfind(b"\n") - 1 if newlines else self._tail + len(data)
        return text

    def _fast_ready(self) -> bool:
        """Lines are read fast before the end record (after it, each is an error)
        and, in CSV, once the header is read."""
        reader = self._reader
        return reader.end is None and (not self._csv or reader.header is not None)

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
