"""CSV chunks read at once, for `rmv eval`'s trace stream (rmvdsl.logic.traces): a
chunk is split at its newlines and commas by the interpreter's string methods, each
column a slice of the cells, whatever the header's order (`t,state`, `state,t`,
`t,props,end`...). A chunk where that reading could differ from the full reader's
(a quoted cell, a row of another width, a time that is not plain digits with a
point or sign, an end row) goes to the full reader, which explains any problem."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import repeat

from rmvdsl.logic.trace_chunks import decimal_floats
from rmvdsl.logic.trace_lines import NAME, csv_state

COLUMNS = frozenset({"t", "state", "props", "end"})
# What a time the fast path takes is written with: float() reads it as `exact` does
# (`5.`, `.5`, `-0`, `007`), and anything float() refuses goes to the full reader.
_NOT_TIME = str.maketrans("", "", "0123456789.-")


# A chunk's times as written and as floats, and its names cells.
Split = tuple[list[str], list[float], list[str]]


@dataclass(frozen=True)
class CsvRows:
    """The rows of one header: how many cells each has, where the time and the
    names are, where the end column is (None: there is none), and whether the names
    are a `;` list (`props`)."""

    width: int
    time_at: int
    names_at: int
    end_at: int | None
    props: bool

    def split(self, lines: str, count: int) -> Split | None:
        """The times (as written and as floats) and names cells of a chunk of `count`
        rows, or None where a row is not a plain sample written plainly."""
        if '"' in lines:  # quoting: the csv module's reading
            return None
        rows = (lines[:-1] if lines.endswith("\n") else lines).split("\n")
        width = self.width
        # every row of the header's width (a short row beside a long one would
        # otherwise shift the columns of the rows after it)
        if (
            len(rows) != count
            or list(map(str.count, rows, repeat(",", count))).count(width - 1) != count
        ):
            return None
        cells = ",".join(rows).split(",")
        if self.end_at is not None and "".join(cells[self.end_at :: width]).strip():
            return None  # the end row, or an end cell the full reader reads
        texts = cells[self.time_at :: width]
        if "".join(texts).translate(_NOT_TIME):  # spaces, a carriage return, or no time
            texts = [text.strip() for text in texts]
            if "".join(texts).translate(_NOT_TIME):
                return None
        times = decimal_floats(texts)  # None: an empty cell, `1.2.3`, `-`, 101 digits
        return None if times is None else (texts, times, cells[self.names_at :: width])

    def plain_run(self, lines: str, count: int) -> tuple[int, Split | None]:
        """How many rows of a chunk, from the first, `split` reads, and their split:
        all of them mostly; all but the last where that is the end row or a blank
        line, as at the end of a file; else the rows before the first it does not
        read (found a row at a time: 3 µs a row, once)."""
        whole = self.split(lines, count)
        if whole is not None:
            return count, whole
        rows = lines.split("\n", count)[:count]
        if count > 1 and self.split(rows[-1], 1) is None:
            but_last = self.split("\n".join(rows[:-1]), count - 1)
            if but_last is not None:
                return count - 1, but_last
        taken = next((i for i, row in enumerate(rows) if self.split(row, 1) is None), count)
        run = self.split("\n".join(rows[:taken]), taken) if taken else None
        return (taken, run) if run is not None else (0, None)  # (0: the first row alone)

    def state(self, cell: str) -> frozenset[str] | None:
        """The propositions a names cell holds; None where one is no proposition
        name (the full reader reports it)."""
        names = csv_state(cell.strip(), self.props)
        return names if all(NAME.fullmatch(name) for name in names) else None


def rows_of(header: list[str]) -> CsvRows | None:
    """The fast reading of a header's rows (None: a header it does not take)."""
    if len(set(header)) != len(header) or not set(header) <= COLUMNS:
        return None
    named_by = "state" if "state" in header else "props"
    end = header.index("end") if "end" in header else None
    return CsvRows(len(header), header.index("t"), header.index(named_by), end, named_by == "props")
