"""A chunk of JSON Lines decoded at once (msgspec), for `rmv eval`'s trace stream
(rmvdsl.logic.traces): the records in any key order, extra fields ignored (the
first one noted), times as floats where a float holds the decimal written exactly."""

from __future__ import annotations

import re
import sys
from fractions import Fraction
from typing import Any

import msgspec

from rmvdsl.lang.numbers import exact_or_quotient
from rmvdsl.logic.trace_lines import LineReader

SCALE = 10**9  # a stream's times: whole billionths of the trace's unit

# A time a float may not hold exactly: 16 or more digits, or an exponent. (A decimal
# of at most 15 significant digits is its float's shortest repr, and floats order
# as the decimals they were read from, ties apart.) Possessive where the `re`
# module has it (3.11): a third faster, and this scan is a tenth of a plain read.
_ONCE = "+" if sys.version_info >= (3, 11) else ""
_INEXACT = re.compile(
    rf'"t"[ \t\r]*{_ONCE}:[ \t\r]*{_ONCE}-?{_ONCE}(?:[0-9.]{{16}}|[0-9.]*{_ONCE}[eE])'
)


class _Plain(msgspec.Struct, forbid_unknown_fields=True):
    """A sample naming one state, keys in any order: what nearly every line of a
    trace is, decoded a chunk at a time. `props` or `end` present: not plain."""

    t: float
    state: str
    props: msgspec.UnsetType = msgspec.UNSET
    end: msgspec.UnsetType = msgspec.UNSET


class _PlainProps(msgspec.Struct, forbid_unknown_fields=True):
    """A sample naming its propositions (`props`), keys in any order: the other
    common shape, decoded a chunk at a time too."""

    t: float
    props: tuple[str, ...]
    state: msgspec.UnsetType = msgspec.UNSET
    end: msgspec.UnsetType = msgspec.UNSET


# The plain shapes, each with the field that names its state.
_PLAIN = {_Plain: "state", _PlainProps: "props"}


class Record(msgspec.Struct, forbid_unknown_fields=True):
    """Any record of the fast reader: a chunk that is not all plain samples is
    taken one record at a time, and a record of another shape still (a time
    written as a string, say) sends the chunk to the full reader."""

    t: float
    state: str | None = None
    props: tuple[str, ...] | None = None
    end: bool | None = None
    unit: str | None = None


_DECODERS = {
    (shape, strict): msgspec.json.Decoder(
        msgspec.defstruct(shape.__name__, [], bases=(shape,), forbid_unknown_fields=strict)
    )
    for shape in (_Plain, _PlainProps, Record)
    for strict in (True, False)
}
_UNKNOWN = re.compile(r"unknown field `(.*)` - at `\$\[(\d+)\]")


class ChunkDecoder:
    """Decodes chunks strictly (an unknown field is an error) until the first field
    the trace does not use is noted in `reader`, then leniently."""

    def __init__(self, reader: LineReader) -> None:
        self.reader = reader
        self.strict = True

    def decode(self, lines: str, count: int, before: int) -> tuple[str, list[Any]] | None:
        """The chunk's records, one per line, in any key order, with any extra fields
        (the first one noted), and the field naming their states where all are plain
        samples of one shape ("state" or "props"; else ""); None where a line is
        blank or holds a record of another shape, or a time a float may not hold
        exactly."""
        if "\\u" in lines or _INEXACT.search(lines):
            return None
        for shape in (_Plain, _PlainProps, Record):
            while True:
                try:
                    records = _DECODERS[shape, self.strict].decode_lines(lines)
                except msgspec.ValidationError as error:
                    found = _UNKNOWN.search(str(error))
                    if not self.strict or found is None:
                        break  # another shape
                    self.strict = False
                    self.reader.ignore(found[1], before + _line_of(lines, int(found[2])))
                    continue
                except msgspec.DecodeError:
                    return None
                return (_PLAIN.get(shape, ""), records) if len(records) == count else None
        return None

    def records(self, lines: str) -> list[Any]:
        """Every record of a chunk that decoded as plain samples, as general ones."""
        return _DECODERS[Record, self.strict].decode_lines(lines)


def scaled(t: Fraction) -> int | Fraction:
    """A time in billionths of its unit: an int where that is exact."""
    value = t * SCALE
    return value.numerator if value.denominator == 1 else value


def decimal_scaled(text: str) -> int:
    """A decimal of at most 9 decimals, no exponent, in billionths."""
    whole, _, fraction = text.partition(".")
    return int(whole + fraction.ljust(9, "0"))


def float_scaled(value: float) -> int | Fraction:
    """A time the fast reader took as a float, in billionths: its shortest repr is
    the decimal written (at most 15 digits, so exact)."""
    text = repr(value)
    if "e" in text or len(text.partition(".")[2]) > 9:
        return scaled(exact_or_quotient(text))
    return decimal_scaled(text)


def _line_of(lines: str, index: int) -> int:
    """The line (from 1) of the index-th non-blank line of `lines`."""
    for number, raw in enumerate(lines.split("\n"), 1):
        if raw.strip():
            if index == 0:
                return number
            index -= 1
    return 1
