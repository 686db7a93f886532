"""Reading a trace's lines for `rmv eval` (rmvdsl.logic.traces): a chunk of lines
at once where it allows it, one line at a time by the full reader where it does not.

A JSON Lines chunk is decoded at once by msgspec (rmvdsl.logic.trace_chunks), a CSV
chunk split at its newlines and commas (rmvdsl.logic.trace_csv); runs of plain
samples are checked by the interpreter's own loops over their times and keys, and
anything else (the end record, a new name, a time not above the last) goes through
the full reader (rmvdsl.logic.trace_lines), which reports each problem.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Iterator
from fractions import Fraction
from itertools import compress, count, islice
from typing import Any

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
from rmvdsl.logic.trace_lines import LineReader

Change = tuple[int | Fraction, frozenset[str]]  # a time in billionths, the state from it


class LineRuns:
    """The lines of a trace after its unit, chunk by chunk (`_chunk`): a part of
    rmvdsl.logic.traces.TraceStream, which reads the bytes and sets these."""

    _csv: bool
    _reader: LineReader
    _chunks: ChunkDecoder
    _states: dict[StateKey, frozenset[str]]  # of the common lines
    _current: frozenset[str] | None  # the state of the last sample
    _rows_header: list[str] | None  # the CSV header `_rows` reads
    _rows: CsvRows | None
    first: Fraction | None
    samples: int
    seen: set[str]

    def _chunk(self, lines: str, count: int, before: int) -> Iterator[Change]:
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

    def _json_runs(self, lines: str, count: int, before: int) -> Iterator[Change]:
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
    ) -> Iterator[Change]:
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

    def _csv_header(self, lines: str, count: int, before: int) -> Iterator[Change]:
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

    def _csv_runs(self, rows: CsvRows, lines: str, count: int, before: int) -> Iterator[Change]:
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

    def _full_lines(self, lines: str, count: int, before: int) -> Iterator[Change]:
        for index, raw in enumerate(lines.split("\n")[:count]):
            yield from self._full_line(before + index + 1, raw)

    def _fast_plain(
        self, named_by: str, records: list[Any], times: list[float], before: int, lines: str
    ) -> Iterator[Change]:
        """Plain samples, each naming its state by the field `named_by` ("state" or
        "props"). Anything to explain (a time not above the last, a new name that is
        no proposition) is left to the record at a time path."""

        def general() -> Iterator[Change]:
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
        general: Callable[[], Iterator[Change]],
    ) -> Iterator[Change]:
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
    ) -> Iterator[Change]:
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

    def _full_line(self, number: int, raw: str) -> Iterator[Change]:
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

    def _fast_ready(self) -> bool:
        """Lines are read fast before the end record (after it, each is an error)
        and, in CSV, once the header is read."""
        reader = self._reader
        return reader.end is None and (not self._csv or reader.header is not None)
