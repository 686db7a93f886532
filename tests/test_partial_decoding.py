"""rmvdsl.host.partial_decoding against rosbags' full decoders: random message
definitions (nested messages, strings, fixed arrays and sequences of each kind,
every primitive), random values serialised by rosbags as CDR (both byte orders)
and ROS 1, random sets of fields read. What the partial reader gives for each
field read equals what the full decoder's message holds there; a message of the
wrong length fails in both; a damaged message the full decoder still reads, the
partial reader reads alike."""

from __future__ import annotations

import math
from typing import Any

import numpy
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from rmvdsl.host.partial_decoding import (
    PartialDecodeError,
    Unreadable,
    Unsupported,
    compile_reader,
    falling_back,
    guarded,
    needs_of,
    or_full,
)
from rmvdsl.host.wire_reader import MOST_EMPTY

PRIMITIVES = ["bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
              "int64", "uint64", "float32", "float64"]  # fmt: skip
RANGES = {
    "int8": (-128, 127), "byte": (-128, 127), "uint8": (0, 255), "char": (0, 255),
    "int16": (-(2**15), 2**15 - 1), "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1), "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1), "uint64": (0, 2**64 - 1),
}  # fmt: skip
NUMPY = {"bool": "bool_", "char": "uint8", "byte": "int8"}
PLACEHOLDER = "structure_needs_at_least_one_member"  # ROS 2's member of an empty message


@st.composite
def definitions(draw: Any) -> list[tuple[str, list[tuple[str, str]]]]:
    """Up to three message types, each field a primitive, a string, an earlier
    type, or a fixed array or a sequence of one of those; all but the last may
    be empty (ROS 2 gives them one member, ROS 1 writes no bytes for them)."""
    types: list[tuple[str, list[tuple[str, str]]]] = []
    count = draw(st.integers(1, 3))
    for index in range(count):
        fields = []
        for number in range(draw(st.integers(0 if index < count - 1 else 1, 6))):
            base = draw(st.sampled_from([*PRIMITIVES, "string", *(n for n, _ in types)]))
            shape = draw(st.sampled_from(["", "", "[]", f"[{draw(st.integers(0, 3))}]"]))
            fields.append((f"f{number}", base + shape))
        types.append((f"test_msgs/msg/T{index}", fields))
    return types[::-1]  # the message read first, the types it uses after


def _store(types: list[tuple[str, list[tuple[str, str]]]]) -> Any:
    store = get_typestore(Stores.EMPTY)
    for name, fields in types:
        text = "\n".join(f"{kind.replace('test_msgs/msg/', 'test_msgs/')} {field}"
                         for field, kind in fields)  # fmt: skip
        store.register(get_types_from_msg(text, name))
    return store


def _value(draw: Any, store: Any, kind: str) -> Any:
    base, _, shape = kind.partition("[")
    if shape:
        count = int(shape[:-1]) if shape != "]" else draw(st.integers(0, 3))
        items = [_value(draw, store, base) for _ in range(count)]
        if base in PRIMITIVES:
            return numpy.array(items, dtype=getattr(numpy, NUMPY.get(base, base)))
        return items
    if base == "bool":
        return draw(st.booleans())
    if base in RANGES:
        return draw(st.integers(*RANGES[base]))
    if base == "float32":
        return float(numpy.float32(draw(st.floats(width=32, allow_nan=False))))
    if base == "float64":
        return draw(st.floats(allow_nan=False))
    if base == "string":
        return draw(st.text(max_size=6))
    fields = store.fielddefs[base][1]
    cls = store.types[base]
    declared = dict(_declared(store, base))
    return cls(*(_value(draw, store, declared[name]) for name, _ in fields))


def _declared(store: Any, name: str) -> list[tuple[str, str]]:
    """A type's fields as written (`float32[3]`), from rosbags' descriptions."""
    out = []
    for field, (kind, detail) in store.fielddefs[name][1]:
        out.append((field, _written(int(kind), detail)))
    return out


def _written(kind: int, detail: Any) -> str:
    if kind == 1:
        return detail[0]
    if kind == 2:
        return detail
    inner = _written(int(detail[0][0]), detail[0][1])
    return f"{inner}[{detail[1]}]" if kind == 3 else f"{inner}[]"


def _paths(store: Any, name: str, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every path to a field, through each array's elements (None), and to each
    nested message whole."""
    found = []
    for field, (kind, detail) in store.fielddefs[name][1]:
        if field == PLACEHOLDER:  # no field of the message: ROS 1 has no such bytes
            continue
        path = (*prefix, field)
        found.append(path)
        kind = int(kind)
        if kind == 2:
            found += _paths(store, detail, path)
        elif kind in (3, 4) and int(detail[0][0]) == 2:
            found += _paths(store, detail[0][1], (*path, None))
    return found


def _at(value: Any, path: tuple[Any, ...]) -> Any:
    """What a path reads, as plain data (each element's, through None)."""
    if not path:
        return _plain(value)
    step, rest = path[0], path[1:]
    if step is None:
        return [_at(item, rest) for item in value]
    return _at(getattr(value, step), rest)


def _plain(value: Any) -> Any:
    if isinstance(value, numpy.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if hasattr(value, "__slots__") or hasattr(value, "__dataclass_fields__"):
        names = getattr(value, "__dataclass_fields__", None) or value.__slots__
        kept = [n for n in names if not n.startswith("__") and n != PLACEHOLDER]
        return {n: _plain(getattr(value, n)) for n in kept}
    if isinstance(value, float) and math.isnan(value):
        return "nan"
    return value


@st.composite
def cases(draw: Any) -> tuple[Any, str, Any, list[tuple[Any, ...]]]:
    types = draw(definitions())
    store = _store(types)
    top = types[0][0]
    message = _value(draw, store, top)
    paths = _paths(store, top)
    chosen = draw(st.lists(st.sampled_from(paths), min_size=1, max_size=4, unique=True))
    return store, top, message, chosen


FORMATS = ("cdr little", "cdr big", "ros1")


def _serialised(store: Any, top: str, message: Any, wire: str) -> bytes:
    if wire == "ros1":
        return bytes(store.serialize_ros1(message, top))
    return bytes(store.serialize_cdr(message, top, little_endian=wire == "cdr little"))


def _full(store: Any, top: str, raw: bytes, wire: str) -> Any:
    return store.deserialize_ros1(raw, top) if wire == "ros1" else store.deserialize_cdr(raw, top)


def _reader(store: Any, top: str, paths: list[tuple[Any, ...]], wire: str) -> Any:
    """The partial reader, or None where it leaves the definition to the full
    decoder for the one reason random definitions can give: an array of no
    messages in CDR (rosbags lays out what follows it unlike CDR)."""
    fields_of = lambda name: store.fielddefs[name][1]  # noqa: E731
    try:
        return compile_reader(top, needs_of(paths), fields_of, ros1=wire == "ros1")
    except Unsupported as error:
        assert str(error) == "an array of no messages in CDR" and wire != "ros1", error
        assert _has_no_message_array(store, top), error
        return None


def _has_no_message_array(store: Any, name: str) -> bool:
    for _, (kind, detail) in store.fielddefs[name][1]:
        kind = int(kind)
        inner = detail if kind == 2 else detail[0][1] if kind in (3, 4) else None
        if kind == 3 and detail[1] == 0 and int(detail[0][0]) == 2:
            return True
        if isinstance(inner, str) and _has_no_message_array(store, inner):
            return True
    return False


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases(), st.sampled_from(FORMATS))
def test_every_field_read_is_what_the_full_decoder_reads(case: Any, wire: str) -> None:
    """... and what it refuses, the partial reader refuses: rosbags' full decoder
    refuses some bytes its own writer makes (in CDR, a sequence of messages of no
    bytes), and the replay's meaning must not depend on which decoder read them."""
    store, top, message, paths = case
    raw = _serialised(store, top, message, wire)
    reader = _reader(store, top, paths, wire)
    try:
        full = _full(store, top, raw, wire)
    except SerdeError:
        if reader is not None:
            with pytest.raises(PartialDecodeError):
                reader(raw)
        return
    if reader is None:
        return
    partial = reader(raw)
    for path in paths:
        assert _at(partial, path) == _at(full, path), path


def _outcome(read: Any, raw: bytes, paths: list[tuple[Any, ...]]) -> Any:
    """What a decoder makes of `raw` at each path, or why it refuses it."""
    try:
        message = read(raw)
    except Unreadable:
        return "unreadable"
    except Exception as error:
        return "not text" if "codec can't decode" in str(error) else "refused"
    return [_at(message, path) for path in paths]


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases(), st.sampled_from(FORMATS), st.data())
def test_damaged_bytes_are_refused_or_read_as_the_full_decoder_reads_them(
    case: Any, wire: str, data: Any
) -> None:
    """The reader as replay uses it (the full decoder where it refuses a message):
    a message the full decoder refuses is refused, one it reads is read alike."""
    store, top, message, paths = case
    raw = bytearray(_serialised(store, top, message, wire))
    partial = _reader(store, top, paths, wire)
    if partial is None:
        return
    full = lambda raw: _full(store, top, raw, wire)  # noqa: E731
    read = falling_back(partial, full)
    # cut short, or with bytes after its end, or bytes changed in place
    damages = [bytes(raw) + b"\x07" * (4 if wire != "ros1" else 1)]
    if raw:
        damages.append(bytes(raw[: -data.draw(st.integers(1, len(raw)))]))
    start = 0 if wire == "ros1" else 4
    if len(raw) > start:
        flipped = bytearray(raw)
        for _ in range(data.draw(st.integers(1, 4))):
            flipped[data.draw(st.integers(start, len(raw) - 1))] = data.draw(st.integers(0, 255))
        damages.append(bytes(flipped))
    # where nothing reads the message before it, ROS 1's full decoder is guarded
    whole = guarded(full, top, lambda name: store.fielddefs[name][1]) if wire == "ros1" else full
    for damaged in damages:
        unreadable = _outcome(read, damaged, paths) == "unreadable"
        assert (_outcome(whole, damaged, paths) == "unreadable") == unreadable
        if unreadable:
            continue  # rosbags would make each of its millions of empty messages
        expected = _outcome(full, damaged, paths)
        assert _outcome(whole, damaged, paths) == expected
        if expected == "not text":  # a string not read is not decoded (docs/replay.md)
            continue
        assert _outcome(read, damaged, paths) == expected
    # the length is checked whole, bytes read or not: longer is refused by both
    with pytest.raises(PartialDecodeError):
        partial(damages[0])


def test_a_damaged_count_of_empty_messages_is_refused_not_made() -> None:
    """A ROS 1 count of empty messages past MOST_EMPTY is refused, and never given
    to rosbags' decoder, which makes each one: a damaged count of 2^31 took the
    whole machine's memory (the damaged-bytes test drew it once in CI). A count
    past the message's length but within MOST_EMPTY is still the full decoder's."""
    store = _store([("test_msgs/msg/Top", [("items", "test_msgs/msg/Empty[]"), ("x", "uint8")]),
                    ("test_msgs/msg/Empty", [])])  # fmt: skip
    paths = _paths(store, "test_msgs/msg/Top")
    partial = _reader(store, "test_msgs/msg/Top", paths, "ros1")
    given: list[bytes] = []

    def full(raw: bytes) -> Any:
        given.append(raw)
        return _full(store, "test_msgs/msg/Top", raw, "ros1")

    read = falling_back(partial, full)
    damaged = (MOST_EMPTY + 1).to_bytes(4, "little") + b"\x05"
    with pytest.raises(Unreadable, match=f"a count of {MOST_EMPTY + 1} messages of no bytes"):
        read(damaged)
    assert given == []
    many = read((1000).to_bytes(4, "little") + b"\x05")  # longer than its 5 bytes: rosbags'
    assert (len(many.items), many.x, len(given)) == (1000, 5, 1)


def test_the_full_decoder_alone_is_guarded_from_a_damaged_count_of_empty_messages() -> None:
    """Where no partial reader stands before it (a topic read whole, or fields it
    does not compile), ROS 1's full decoder is guarded by a walk of the message
    that refuses the same counts; a type that cannot hold one is not walked."""
    store = _store([("test_msgs/msg/Top", [("items", "test_msgs/msg/Empty[]"), ("x", "uint8")]),
                    ("test_msgs/msg/Empty", []),
                    ("test_msgs/msg/Flat", [("items", "uint8[]"),
                                            ("inner", "test_msgs/msg/Empty")])])  # fmt: skip
    fields_of = lambda name: store.fielddefs[name][1]  # noqa: E731
    given: list[bytes] = []

    def full(raw: bytes) -> Any:
        given.append(raw)
        return _full(store, "test_msgs/msg/Top", raw, "ros1")

    damaged = (MOST_EMPTY + 1).to_bytes(4, "little") + b"\x05"
    nothing_compiles = [needs_of([("no_such_field",)])]
    for read in (guarded(full, "test_msgs/msg/Top", fields_of),
                 or_full(full, "test_msgs/msg/Top", nothing_compiles, fields_of, ros1=True),
                 or_full(full, "test_msgs/msg/Top", [], fields_of, ros1=True)):  # fmt: skip
        with pytest.raises(Unreadable, match=f"a count of {MOST_EMPTY + 1} messages"):
            read(damaged)
        assert given == []
        assert read((3).to_bytes(4, "little") + b"\x05").x == 5
        assert read((1000).to_bytes(4, "little") + b"\x05").x == 5  # past its length: rosbags'
        assert len(given) == 2
        given.clear()
    assert guarded(full, "test_msgs/msg/Flat", fields_of) is full
    assert or_full(full, "test_msgs/msg/Top", nothing_compiles, fields_of, ros1=False) is full

    # a type whose messages cannot be walked first is refused, never given to rosbags
    def undefined(name: str) -> Any:  # Top holds a sequence of a type defined nowhere
        return {"test_msgs/msg/Top": [("items", (4, ((2, "test_msgs/msg/Gone"), 0)))]}[name]

    with pytest.raises(Unreadable, match="cannot be checked before it is decoded: no def"):
        guarded(full, "test_msgs/msg/Top", undefined)(b"\x00" * 4)
    assert given == []


def test_a_count_from_damaged_bytes_does_not_make_the_reader_walk_for_ever() -> None:
    store = _store([("test_msgs/msg/Top", [("items", "test_msgs/msg/Item[]")]),
                    ("test_msgs/msg/Item", [("name", "string")])])  # fmt: skip
    read = compile_reader("test_msgs/msg/Top", needs_of([("items", None, "name")]),
                          lambda name: store.fielddefs[name][1], ros1=True)  # fmt: skip
    with pytest.raises(PartialDecodeError, match="longer than the message"):
        read(b"\xff\xff\xff\xff" + b"\x00" * 8)


def test_a_cdr_reader_reads_either_byte_order_and_refuses_other_headers() -> None:
    """Each byte order's reader checks the encapsulation header itself and hands
    any other on: little-endian (00 01) and big-endian (00 00) are read alike, any
    other header, or a message too short for one, is refused as not CDR."""
    store = _store([("test_msgs/msg/Top", [("x", "uint16")])])
    read = compile_reader("test_msgs/msg/Top", needs_of([("x",)]),
                          lambda name: store.fielddefs[name][1], ros1=False)  # fmt: skip
    assert read(b"\x00\x01\x00\x00\x07\x01").x == 0x0107
    assert read(b"\x00\x00\x00\x00\x01\x07").x == 0x0107
    for raw in (b"\x00\x02\x00\x00\x07\x01", b"\x01\x01\x00\x00\x07\x01", b"\x00"):
        with pytest.raises(PartialDecodeError, match="not CDR"):
            read(raw)


def test_elements_of_no_bytes_are_read_however_many_and_a_damaged_count_is_refused() -> None:
    """ROS 1 gives an empty message no bytes: a sequence of them fits any count
    (found by the random test above: two of them ending a message were refused)."""
    store = _store([("test_msgs/msg/Top", [("x", "bool"), ("items", "test_msgs/msg/Empty[]")]),
                    ("test_msgs/msg/Empty", [])])  # fmt: skip
    message = store.types["test_msgs/msg/Top"](True, [store.types["test_msgs/msg/Empty"]()] * 3)
    raw = bytes(store.serialize_ros1(message, "test_msgs/msg/Top"))
    for paths in ([("x",)], [("items",)], [("items",), ("x",)]):
        read = _reader(store, "test_msgs/msg/Top", paths, "ros1")
        partial, full = read(raw), store.deserialize_ros1(raw, "test_msgs/msg/Top")
        assert [_at(partial, p) for p in paths] == [_at(full, p) for p in paths]
    with pytest.raises(PartialDecodeError, match="longer than the message"):
        read(raw[:1] + b"\xff\xff\xff\xff")


def test_a_cdr_sequence_of_messages_of_no_bytes_is_refused_as_rosbags_refuses_it() -> None:
    """rosbags' CDR decoder takes each element of a sequence of messages for one
    byte at least, and refuses a count longer than the bytes left, though a message
    of arrays of length 0 takes none (its writer writes them): the partial reader
    refused only a count past the message's length, so it read what the full
    decoder refuses (found by the random test above). ROS 1 reads any count."""
    store = _store([("test_msgs/msg/Top", [("x", "bool"), ("items", "test_msgs/msg/Zero[]"),
                                           ("y", "bool")]),
                    ("test_msgs/msg/Zero", [("none", "bool[0]")])])  # fmt: skip
    zero = store.types["test_msgs/msg/Zero"](numpy.array([], dtype=bool))
    message = store.types["test_msgs/msg/Top"](True, [zero, zero], False)
    raw = bytes(store.serialize_cdr(message, "test_msgs/msg/Top"))
    with pytest.raises(SerdeError):
        store.deserialize_cdr(raw, "test_msgs/msg/Top")
    with pytest.raises(PartialDecodeError, match="longer than the message"):
        _reader(store, "test_msgs/msg/Top", [("x",)], "cdr little")(raw)
    ros1 = bytes(store.serialize_ros1(message, "test_msgs/msg/Top"))
    assert _reader(store, "test_msgs/msg/Top", [("y",), ("items",)], "ros1")(ros1).y is False


def test_an_array_of_no_messages_in_cdr_is_left_to_the_full_decoder() -> None:
    """rosbags writes and reads `Item[0]` followed by an int32 with no padding
    when Item ends in an int32: it takes the position as aligned by the last
    element, though there is none. CDR pads; the replay reads such a definition
    with rosbags' full decoder, so it reads what rosbags reads (found by the
    random test above, with seed 205792332317880450579786275169557758213)."""
    store = _store([("test_msgs/msg/Top", [("x", "bool"), ("none", "test_msgs/msg/Item[0]"),
                                           ("y", "int32")]),
                    ("test_msgs/msg/Item", [("a", "bool"), ("b", "int32")])])  # fmt: skip
    message = store.types["test_msgs/msg/Top"](True, [], 7)
    raw = bytes(store.serialize_cdr(message, "test_msgs/msg/Top"))
    assert raw[4:] == b"\x01\x07\x00\x00\x00"  # y unpadded, at offset 1
    fields_of = lambda name: store.fielddefs[name][1]  # noqa: E731
    with pytest.raises(Unsupported, match="no messages"):
        compile_reader("test_msgs/msg/Top", needs_of([("y",)]), fields_of, ros1=False)
    full = lambda raw: store.deserialize_cdr(raw, "test_msgs/msg/Top")  # noqa: E731
    read = or_full(full, "test_msgs/msg/Top", [needs_of([("y",)])], fields_of, ros1=False)
    assert read is full and read(raw).y == 7
    ros1 = _reader(store, "test_msgs/msg/Top", [("y",)], "ros1")  # no alignment there
    assert ros1(bytes(store.serialize_ros1(message, "test_msgs/msg/Top"))).y == 7


def test_what_it_cannot_read_it_says_when_compiling() -> None:
    store = _store([("test_msgs/msg/Top", [("x", "float64")])])
    fields_of = lambda name: store.fielddefs[name][1]  # noqa: E731
    with pytest.raises(Unsupported, match="no field"):
        compile_reader("test_msgs/msg/Top", needs_of([("y",)]), fields_of, ros1=False)
    with pytest.raises(Unsupported, match="no definition"):
        compile_reader("test_msgs/msg/Other", needs_of([("x",)]), fields_of, ros1=False)


def test_a_definition_that_contains_itself_is_left_to_the_full_decoder() -> None:
    fields = {"test_msgs/msg/Loop": [("next", (2, "test_msgs/msg/Loop")), ("x", (1, ("int32", 0)))]}
    with pytest.raises(Unsupported, match="nested too deep"):
        compile_reader("test_msgs/msg/Loop", needs_of([("x",)]), fields.__getitem__, ros1=True)


def test_a_primitive_it_does_not_know_anywhere_is_left_to_the_full_decoder() -> None:
    """float128 inside the elements of a sequence not read: the reader must size
    them to skip them, cannot, and says so when compiling (never a KeyError)."""
    fields = {
        "test_msgs/msg/A": [("x", (1, ("int32", 0))), ("items", (4, ((2, "test_msgs/msg/B"), 0)))],
        "test_msgs/msg/B": [("y", (1, ("float128", 0))), ("s", (1, ("string", 0)))],
    }
    for ros1 in (True, False):
        with pytest.raises(Unsupported, match="float128"):
            compile_reader("test_msgs/msg/A", needs_of([("x",)]), fields.__getitem__, ros1=ros1)


@pytest.mark.parametrize("name", ["self", "_self", "raw", "p", "len", "class", "__init__", "a b"])
def test_any_field_name_is_read_or_left_to_the_full_decoder(name: str) -> None:
    """Field names reach generated code only as checked identifiers: one that
    shadows a parameter or a builtin is read; one that is no name is refused when
    compiling."""
    fields = {"test_msgs/msg/A": [(name, (1, ("int32", 0))), ("y", (1, ("int32", 0)))]}
    needs = needs_of([(name,), ("y",)])
    if not name.isidentifier() or name in ("class", "__init__", "_self"):
        with pytest.raises(Unsupported):
            compile_reader("test_msgs/msg/A", needs, fields.__getitem__, ros1=True)
        return
    message = compile_reader("test_msgs/msg/A", needs, fields.__getitem__, ros1=True)(
        (7).to_bytes(4, "little") + (9).to_bytes(4, "little")
    )
    assert (getattr(message, name), message.y) == (7, 9)
