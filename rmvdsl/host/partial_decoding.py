"""Serialized ROS messages read for the fields a spec reads, and no others.

A full decoder (rosbags') builds every field of every message: an object per
nested message, a numpy array per array, a str per string. A spec reads a few
fields (`vehicle_status.control.brake`, `objects.objects[*].twist.linear.x`), so a
reader compiled once per message type and set of fields (`compile_reader`; the
code generator is rmvdsl.host.wire_reader) walks
the bytes by the definition, skips what is not read by its size (a run of
fixed-size fields is one offset, known when compiling; a string or a sequence is
skipped by its length), and unpacks each run of read fields with one
`struct.Struct`. What it returns reads like the full decoder's message for every
field read: the same names, nested objects, sequences of elements, and the same
Python values (docs/replay.md, "Reading only what the spec reads").

Both wire formats rosbags reads: ROS 2's CDR (either byte order, every primitive
aligned to its size from the end of the 4-byte encapsulation header, lengths to 4,
strings NUL-terminated) and ROS 1's (little-endian, packed). A message whose length
does not fit its definition, or whose read bytes do not decode, raises
`PartialDecodeError`; its caller then decodes it fully, which says what is wrong in
rosbags' words. A type this reader does not handle (float128, wstring, a field
name that is not an identifier) raises `Unsupported` when compiling: the caller
keeps the full decoder for it.

The definitions come as rosbags' field descriptions (`Typestore.fielddefs`):
`(name, (kind, detail))` with kind 1 a primitive or string, 2 a nested message, 3
a fixed-size array and 4 a sequence (rosbags.interfaces.Nodetype).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Iterable, Sequence
from typing import Any

from rmvdsl.host.wire_reader import (
    ARRAY,
    NAME,
    SEQUENCE,
    FieldsOf,
    Needs,
    PartialDecodeError,
    Reader,
    Unreadable,
    Unsupported,
    compiled,
    fewest_bytes,
)
from rmvdsl.runtime import spec as ir

__all__ = [
    "FieldsOf", "Needs", "PartialDecodeError", "Reader", "Undefined", "Unreadable",
    "Unsupported",
    "compile_reader", "definitions_reached",
    "falling_back", "guarded", "merged", "needs_of", "or_full", "spec_needs",
]  # fmt: skip


def needs_of(paths: Iterable[Sequence[str | None]]) -> Needs:
    """The fields read along `paths`: each a sequence of field names, None for a
    step into an array's elements (`[3]` or `[*]`)."""
    needs: Needs = {}
    for path in paths:
        names = [step for step in path if step is not None]
        if not names:
            raise Unsupported("a path that reads the whole message")
        level: Needs | None = needs
        for depth, name in enumerate(names):
            assert level is not None
            last = depth == len(names) - 1
            if name in level and level[name] is None:
                break  # all of this field is read already
            if last:
                level[name] = None
                break
            level = level.setdefault(name, {})
    return needs


def spec_needs(spec: ir.Spec, skipped: Iterable[str] = ()) -> dict[str, Needs]:
    """What the spec reads of each topic (by its ROS name): its variables' paths
    (but those in `skipped`), and the stamp of a topic timed by its header."""
    names = {topic.name: topic.ros_name for topic in spec.topics}
    paths: dict[str, list[list[str | None]]] = {}
    leave_out = set(skipped)
    for variable in spec.variables:
        if variable.name not in leave_out:
            steps = [s.read if isinstance(s, ir.FieldStep) else None for s in variable.path]
            paths.setdefault(names[variable.topic], []).append(steps)
    for topic in spec.topics:
        if topic.time_source == "header" and topic.ros_name in paths:
            paths[topic.ros_name].append(["header", "stamp"])
    # a path of no field reads the whole message: that topic is decoded whole
    return {
        topic: needs_of(found)
        for topic, found in paths.items()
        if all(any(step is not None for step in path) for path in found)
    }


def merged(first: Needs, second: Needs) -> Needs:
    """What either reads."""
    out: Needs = dict(first)
    for name, inner in second.items():
        if name not in out:
            out[name] = inner
        else:
            mine = out[name]
            out[name] = None if mine is None or inner is None else merged(mine, inner)
    return out


def or_full(
    full: Reader, type_name: str, wanted: Sequence[Needs], fields_of: FieldsOf, *, ros1: bool
) -> Reader:
    """A reader of the first of `wanted` this module compiles for `type_name`,
    falling back to `full` where it refuses a message; `full` itself where none
    compiles (or nothing is wanted), guarded in ROS 1."""
    for needs in wanted:
        if not needs:
            continue
        try:
            partial = compile_reader(type_name, needs, fields_of, ros1=ros1)
        except Unsupported:
            continue
        return falling_back(partial, full)
    return guarded(full, type_name, fields_of) if ros1 else full


def falling_back(partial: Reader, full: Reader) -> Reader:
    """`partial`, and `full` where it refuses a message: the full decoder then
    reads it, or says in its words what is wrong with it; but not a message it
    must not be given (Unreadable)."""

    def read(raw: bytes | memoryview) -> Any:
        try:
            return partial(raw)
        except Unreadable:
            raise
        except PartialDecodeError:
            return full(raw)

    return read


def guarded(full: Reader, type_name: str, fields_of: FieldsOf) -> Reader:
    """ROS 1's `full` decoder, where nothing reads a message before it: behind a
    walk of each message that refuses what `full` must not be given (Unreadable,
    a count of messages of no bytes past MOST_EMPTY), for a type that can hold
    one; `full` itself for any other type (the walk would cost a message's read).
    A type whose messages cannot be walked is refused whole, message by message:
    rosbags' decoder, given one damaged count, takes the machine's memory. (CDR
    needs no guard: rosbags refuses a count longer than the bytes left.)"""
    try:
        if not _holds_counts_of_nothing(type_name, fields_of):
            return full
        walk = compile_reader(type_name, {}, fields_of, ros1=True)
    except Unsupported as error:
        refusal = Unreadable(f"{type_name} cannot be checked before it is decoded: {error}")

        def refuse(raw: bytes | memoryview) -> Any:
            raise refusal

        return refuse

    def read(raw: bytes | memoryview) -> Any:
        try:
            walk(raw)
        except Unreadable:
            raise
        except PartialDecodeError:
            pass  # damaged otherwise: the full decoder says how, in its words
        return full(raw)

    return read


def _holds_counts_of_nothing(type_name: str, fields_of: FieldsOf) -> bool:
    """Whether a ROS 1 message of `type_name` can hold a sequence of elements of
    no bytes (empty messages), whose count nothing in the message bounds."""
    try:
        reached = definitions_reached(type_name, fields_of)
    except Undefined as error:
        raise Unsupported(f"no definition of {error.name}") from None
    for fields in reached.values():
        for _, (kind, detail) in fields:
            if int(kind) == SEQUENCE and fewest_bytes(detail[0], fields_of, ros1=True) == 0:
                return True
    return False


def compile_reader(type_name: str, needs: Needs, fields_of: FieldsOf, *, ros1: bool) -> Reader:
    """A reader of `type_name`'s serialized messages that decodes `needs`; made
    once per process for each definition and set of fields (a fleet of
    recordings of one type compiles it once)."""
    key = (type_name, repr(needs), ros1, _fingerprint(type_name, fields_of))
    made = _COMPILED.get(key)
    if made is None:
        made = _COMPILED[key] = compiled(type_name, needs, fields_of, ros1=ros1)
        if len(_COMPILED) > KEPT:
            _COMPILED.popitem(last=False)
    return made


KEPT = 256  # readers kept: memory stays flat over any fleet of definitions
_COMPILED: OrderedDict[tuple[str, str, bool, str], Reader] = OrderedDict()


def _fingerprint(type_name: str, fields_of: FieldsOf) -> str:
    """The definitions `type_name` reaches, as text: two versions of a type differ."""
    try:
        return repr(sorted(definitions_reached(type_name, fields_of).items()))
    except Undefined as error:
        raise Unsupported(f"no definition of {error.name}") from None


class Undefined(KeyError):
    """A type reached that has no definition (`name`)."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.name = name


def definitions_reached(type_name: str, fields_of: FieldsOf) -> dict[str, tuple[Any, ...]]:
    """The fields of `type_name` and of every type it holds, by name; raises
    Undefined naming the first one `fields_of` has no definition of."""
    seen: dict[str, tuple[Any, ...]] = {}
    waiting = [type_name]
    while waiting:
        name = waiting.pop()
        if name in seen:
            continue
        try:
            fields = seen[name] = tuple(fields_of(name))
        except KeyError:
            raise Undefined(name) from None
        for _, (kind, detail) in fields:
            kind = int(kind)
            if kind == NAME:
                waiting.append(detail)
            elif kind in (ARRAY, SEQUENCE) and int(detail[0][0]) == NAME:
                waiting.append(detail[0][1])
    return seen
