"""CSV chunks read at once, for `rmv eval`'s trace stream (rmvdsl.logic.traces):
one regular expression per header, built from its columns in the order written
(`t,state`, `state,t`, `t,props,end`...), matching each row of a plain sample. A
chunk any of whose rows it does not match (a quoted cell, a time written as a
quotient, the end row, a blank line) goes to the full reader."""

from __future__ import annotations

import re
from dataclasses import dataclass

from rmvdsl.logic.trace_lines import NAME, csv_state

# A time exact in billionths and within range, as the fast path converts it.
_DECIMAL = r"(-?(?:0|[1-9][0-9]{0,14})(?:\.[0-9]{1,9})?)"
_NAME = NAME.pattern
_SPACE = r"[ \t]*"
# Each column's cell; `t` and the column naming the state are captured.
_CELLS = {
    "t": _DECIMAL,
    "state": rf"({_NAME})?",
    "props": rf"((?:{_NAME}(?:{_SPACE};{_SPACE}{_NAME})*)?)",
    "end": "",  # empty: a sample (a row that ends the trace goes to the full reader)
}
_IGNORED_PROPS = r'[^,"\r\n]*'  # beside a `state` column, `props` is not read


@dataclass(frozen=True)
class CsvRows:
    """The rows of one header: `pattern` finds (time, names) or (names, time) in
    each, `time_first` says which; `props` whether the names are a `;` list."""

    pattern: re.Pattern[str]
    time_first: bool
    props: bool

    def split(self, lines: str, count: int) -> tuple[list[str], list[str]] | None:
        """The times and names cells of a chunk of `count` rows, or None where a
        row is not a plain sample written plainly."""
        found = self.pattern.findall(lines)
        if not found or len(found) != count:
            return None
        first, second = (list(column) for column in zip(*found, strict=True))
        return (first, second) if self.time_first else (second, first)

    def state(self, cell: str) -> frozenset[str]:
        """The propositions a names cell holds (its names matched the pattern)."""
        return csv_state(cell, self.props)


def rows_of(header: list[str]) -> CsvRows | None:
    """The fast reading of a header's rows (None: a header it does not take)."""
    if len(set(header)) != len(header) or not set(header) <= set(_CELLS):
        return None
    named_by = "state" if "state" in header else "props"
    cells = []
    for column in header:
        cell = _CELLS[column]
        if column == "props" and named_by == "state":
            cell = _IGNORED_PROPS
        cells.append(_SPACE + cell + _SPACE)
    pattern = re.compile("^" + ",".join(cells) + r"\r?$", re.M)
    captured = [column for column in header if column in ("t", named_by)]
    return CsvRows(pattern, captured[0] == "t", named_by == "props")
