"""A chunk of JSON Lines decoded at once (msgspec), for `rmv eval`'s trace stream
(rmvdsl.logic.traces): the records in any key order, extra fields ignored (the
first one noted), each time kept as the text written and read as a float besides."""

from __future__ import annotations

import re
from bisect import bisect_left, bisect_right
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import msgspec

from rmvdsl.lang.numbers import MAX_DIGITS, MAX_MAGNITUDE, NumberError, exact_or_quotient
from rmvdsl.logic.trace_lines import NAME, LineReader

SCALE = 10**9  # a stream's times: whole billionths of the trace's unit

# Every time of a chunk as a float, from the texts joined into one JSON array: a
# float orders no two times the wrong way round (it may tie them), so the floats
# check the order and the text of a time gives its exact value where one is needed
# (the times where the state changes, the last). A time written as a string ("12.5",
# "1/3") is read exactly and rounded to its float; a time that is no number, or one
# out of a float's range, leaves the chunk to the full reader.
_FLOATS = msgspec.json.Decoder(list[float])
_FLOATS_OR_TEXTS = msgspec.json.Decoder(list[float | str])

# The times `exact` reads (rmvdsl.lang.numbers): at most MAX_DIGITS digits, a
# magnitude within 10^-MAX_MAGNITUDE..10^MAX_MAGNITUDE. A fast path takes a time
# only where it surely is one (its text no longer than MAX_DIGITS, its float a
# little inside those magnitudes, or read exactly); any other goes to the full
# reader, which reports it. (Before, a time of 150 digits, or of 1e-400, between two
# changes was taken silently, and 1e305 as a trace's last time stopped `rmv eval`
# with an internal error.)
LARGEST = 10.0 ** (MAX_MAGNITUDE - 1)
SMALLEST = 10.0 ** (1 - MAX_MAGNITUDE)


# The decoded records hold numbers, strings and tuples of strings, never a cycle:
# they are kept out of the garbage collector's books (gc=False), which a chunk's
# 10,000s of new objects would otherwise send through its young generation.


class _Plain(msgspec.Struct, gc=False):
    """A sample naming one state, keys in any order: what nearly every line of a
    trace is, decoded a chunk at a time. `props` or `end` present: not plain."""

    t: msgspec.Raw
    state: str


class _PlainProps(msgspec.Struct, gc=False):
    """A sample naming its propositions (`props`), keys in any order: the other
    common shape, decoded a chunk at a time too."""

    t: msgspec.Raw
    props: tuple[str, ...]


# The plain shapes, each with the field that names its state.
_PLAIN = {_Plain: "state", _PlainProps: "props"}
# A plain sample holds none of these: decoded strictly, such a field is unknown,
# which says the line has another shape (a unit record's `unit` is no field a
# sample ignores); decoded leniently (unknown fields ignored), the plain shapes
# declare them as fields no value fits.
_OTHER_SHAPES: dict[type, tuple[str, ...]] = {
    _Plain: ("props", "end", "unit"),
    _PlainProps: ("state", "end", "unit"),
}


class Record(msgspec.Struct, forbid_unknown_fields=True, gc=False):
    """Any record of the fast reader: a chunk that is not all plain samples is
    taken one record at a time, and a record of another shape still (a time
    written as a string, say) sends the chunk to the full reader."""

    t: msgspec.Raw
    state: str | None = None
    props: tuple[str, ...] | None = None
    end: bool | None = None
    unit: str | None = None


def _decoder(shape: type, strict: bool) -> msgspec.json.Decoder[Any]:
    """A shape's decoder of a chunk (`as_array`): strict (an unknown field is an
    error) or lenient."""
    guarded = () if strict else _OTHER_SHAPES.get(shape, ())
    guards = [(name, msgspec.UnsetType, msgspec.UNSET) for name in guarded]
    struct = msgspec.defstruct(
        shape.__name__, guards, bases=(shape,), forbid_unknown_fields=strict, gc=False
    )
    return msgspec.json.Decoder(list[struct])  # type: ignore[valid-type]  # (made at run time)


def as_array(lines: str) -> str:
    """A chunk's lines as one JSON array, a line an item: msgspec's `decode_lines`
    reads a stream of values, so `{...} {...}` on one line, or an object over two
    lines, made as many records as lines where the full reader refuses both; in an
    array each is malformed. (The replace and the brackets copy the chunk: 3-5% more
    instructions a line than `decode_lines`, counted over 200,000 lines.)"""
    items = (lines[:-1] if lines.endswith("\n") else lines).replace("\n", ",")
    return f"[{items}]"  # one copy; `"[" + items + "]"` made two


_DECODERS = {
    (shape, strict): _decoder(shape, strict)
    for shape in (_Plain, _PlainProps, Record)
    for strict in (True, False)
}
_UNKNOWN = re.compile(r"unknown field `(.*)` - at `\$\[(\d+)\]")
_AT = re.compile(r"- at `\$\[(\d+)\]")


# A chunk decoded at once: the field naming the states of all its records where they
# are plain samples of one shape (else ""), the records, their times as floats.
Decoded = tuple[str, list[Any], list[float]]


class ChunkDecoder:
    """Decodes chunks strictly (an unknown field is an error) until the first field
    the trace does not use is noted in `reader`, then leniently."""

    def __init__(self, reader: LineReader) -> None:
        self.reader = reader
        self.strict = True

    def decode(self, lines: str, count: int, before: int) -> Decoded | int | None:
        """The chunk's records, one per line, in any key order, with any extra fields
        (the first one noted), their times as floats, and the field naming their
        states where all are plain samples of one shape ("state" or "props"; else
        ""); None where a line is blank or holds a record of another shape, or a
        time that is not a number a float can order. Where the first records are
        plain samples of one shape and a later one is not (the end record, say),
        the number of those first ones (records, not lines: a blank line is none)."""
        if "\\" in lines and "\\u" in lines:  # (a backslash is rare: found fast)
            return None  # json reads escapes msgspec refuses (a lone surrogate)
        for shape in (_Plain, _PlainProps, Record):
            while True:
                try:
                    records = _DECODERS[shape, self.strict].decode(as_array(lines))
                except msgspec.ValidationError as error:
                    found = _UNKNOWN.search(str(error))
                    if not self.strict or found is None or _of_another_shape(shape, found[1]):
                        plain = _plain_before(shape, str(error))
                        if plain:
                            return plain
                        break  # another shape
                    self.strict = False
                    self.reader.ignore(found[1], before + _line_of(lines, int(found[2])))
                    continue
                except msgspec.DecodeError:
                    return None
                if len(records) != count:
                    return None
                times = float_times(records)
                return None if times is None else (_PLAIN.get(shape, ""), records, times)
        return None

    def records(self, lines: str) -> tuple[list[Any], list[float]] | None:
        """Every record of a chunk that decoded as plain samples, as general ones,
        and their times as floats."""
        records = _DECODERS[Record, self.strict].decode(as_array(lines))
        times = float_times(records)
        return None if times is None else (records, times)


def _plain_before(shape: type, error: str) -> int:
    """How many records a plain shape's decoder read before the one its error is
    about (0 for the general shape)."""
    found = _AT.search(error)
    return int(found[1]) if found and shape in _PLAIN else 0


def _of_another_shape(shape: type, name: str) -> bool:
    return name in _OTHER_SHAPES.get(shape, ())


StateKey = str | tuple[str, ...]  # one proposition's name, or the list a `props` line names


def propositions(key: StateKey) -> frozenset[str] | None:
    """The state a JSON Lines key names, if its names are propositions' (else the
    full reader reports them)."""
    names = (key,) if isinstance(key, str) else key
    return frozenset(names) if all(NAME.fullmatch(name) for name in names) else None


def float_times(records: list[Any]) -> list[float] | None:
    """The records' times as floats (None: one is not a number, or out of range, or
    written longer than any time `exact` reads)."""
    texts = [r.t for r in records]
    if too_long(texts):
        return None
    joined = b"[%s]" % b",".join(texts)
    try:
        times: list[float] = _FLOATS.decode(joined)
    except msgspec.MsgspecError:
        try:
            values: list[float | str] = _FLOATS_OR_TEXTS.decode(joined)
            return [v if isinstance(v, float) else _text_float(v) for v in values]
        except (msgspec.MsgspecError, NumberError, OverflowError):
            return None
    return times


def readable(times: list[float], text_at: Callable[[int], str]) -> bool:
    """Whether `exact` reads every time of a chunk whose floats increase: its ends
    are inside the magnitudes, and the times near 0 (where a float may have lost
    one below them) are read exactly."""
    if not (times[0] > -LARGEST and times[-1] < LARGEST):  # (not: a NaN is out too)
        return False
    if times[0] < SMALLEST and times[-1] > -SMALLEST:
        for index in range(bisect_right(times, -SMALLEST), bisect_left(times, SMALLEST)):
            try:
                exact_or_quotient(text_at(index))
            except NumberError:
                return False
    return True


def too_long(texts: list[Any]) -> bool:
    """Whether a time is written longer than any `exact` reads (its length, looked
    at for every time of a chunk, is 4% of reading plain lines)."""
    return max(map(len, texts), default=0) > MAX_DIGITS


def decimal_floats(texts: list[str]) -> list[float] | None:
    """Texts of digits, points and signs as floats (as float() reads them, and
    `exact`: `5.`, `.5`, `007`): decoded as one JSON array where they are JSON
    numbers, as most are (a fifth of the time of float() on each); None where one is
    no number (`1.2.3`, `-`, an empty text) or longer than any `exact` reads."""
    if too_long(texts):
        return None
    try:
        floats: list[float] = _FLOATS.decode(("[" + ",".join(texts) + "]").encode())
        # one empty text is an empty array: a float for each text, or none at all
        return floats if len(floats) == len(texts) else None
    except msgspec.MsgspecError:
        try:
            return list(map(float, texts))
        except ValueError:
            return None


def _text_float(text: str) -> float:
    """A time written as a string, checked as the full reader reads it, as the
    float nearest its exact value."""
    text = text.strip()
    return float(text) if _is_decimal(text) else float(exact_or_quotient(text))


def _is_decimal(text: str) -> bool:
    """Digits, a sign before them and one point among them (what float() and
    `exact` read alike)."""
    whole, point, fraction = text.partition(".")
    digits = whole[1:] if whole[:1] == "-" else whole
    return (
        digits.isascii()
        and digits.isdigit()
        and (not point or (fraction.isascii() and fraction.isdigit()))
    )


def time_text(record: Any) -> str:
    """A decoded record's time as written: a number's text, or a string's (which
    the reader strips)."""
    text = str(record.t, "utf-8")
    return text if text[0] != '"' else msgspec.json.decode(text, type=str).strip()


def scaled(t: Fraction) -> int | Fraction:
    """A time in billionths of its unit: an int where that is exact."""
    value = t * SCALE
    return value.numerator if value.denominator == 1 else value


def text_scaled(text: str) -> int | Fraction:
    """A time's text (`time_text`), in billionths, exact: a decimal of at most 9
    decimals by integer arithmetic, anything else (an exponent, a quotient) by
    `exact_or_quotient`, the full reader's own reading."""
    if text.isdigit() and text.isascii():  # a whole number (a row count, say)
        return int(text) * SCALE
    whole, point, fraction = text.partition(".")
    if len(fraction) <= 9 and _is_decimal(text):
        return int(whole + fraction.ljust(9, "0")) if point else int(whole) * SCALE
    return scaled(exact_or_quotient(text))


def _line_of(lines: str, index: int) -> int:
    """The line (from 1) of the index-th non-blank line of `lines`."""
    for number, raw in enumerate(lines.split("\n"), 1):
        if raw.strip():
            if index == 0:
                return number
            index -= 1
    return 1
