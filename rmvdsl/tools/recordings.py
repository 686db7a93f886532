"""A recording as `rmv replay` reads it (docs/replay.md): rosbags' AnyReader over
ROS 1 `.bag` and ROS 2 `.db3`/`.mcap` files with the recording's own definitions,
the spec's topics matched with its connections before the first message, its
messages given up to where the bytes cannot be read further, each decoded for the
fields the spec reads (rmvdsl.host.partial_decoding), and a reader's errors said in
a user's words."""

from __future__ import annotations

import heapq
import struct
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rmvdsl.host import definitions, partial_decoding
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import os_words
from rmvdsl.tools.typestores import (
    connection_store,
    default_store,
    deferred_default_store,
    shared_store,
)


class ReplayError(Exception):
    """A recording that cannot be read at all (the CLI exits 2)."""


@dataclass
class Plan:
    """What the recording holds for the spec: the connections to read and what
    was found wrong before reading."""

    connections: list[Any] = field(default_factory=list)
    problems: list[tuple[str, str]] = field(default_factory=list)  # (origin, text)
    skipped_variables: set[str] = field(default_factory=set)
    skipped_messages: dict[str, int] = field(default_factory=dict)  # counter -> count


def _undefined(store: Any, msgtype: str) -> str | None:
    """The first type of a message (itself or one it holds) the store has no
    definition of."""
    try:
        partial_decoding.definitions_reached(msgtype, lambda name: store.fielddefs[name][1])
    except partial_decoding.Undefined as error:
        return error.name
    return None


def _fill_undefined(reader: Any, spec: ir.Spec) -> None:
    """A rosbag2 recording may hold the definitions of some types and not of others
    (recordings merged from two distributions): rosbags then reads none of the
    default types, and the replay stopped on the first type it lacked. The types
    it lacks are taken from the default store, as for a recording holding none."""
    store = reader.typestore
    if not reader.is2 or all(_undefined(store, c.msgtype) is None for c in reader.connections):
        return
    default = default_store(spec).fielddefs
    store.register(
        {name: fields for name, fields in default.items() if name not in store.fielddefs}
    )


def plan(spec: ir.Spec, reader: Any) -> Plan:
    """Match the spec's topics with the recording's connections."""
    found = Plan()
    by_topic: dict[str, list[Any]] = {}
    for connection in reader.connections:
        by_topic.setdefault(connection.topic, []).append(connection)
    variables: dict[str, list[ir.Variable]] = {}
    for variable in spec.variables:
        variables.setdefault(variable.topic, []).append(variable)
    origins = {v.name: v.origin for v in spec.variables}
    for topic in spec.topics:
        connections = by_topic.get(topic.ros_name, [])
        if not connections:
            found.problems.append((
                topic.origin,
                f"topic `{topic.name}` ({topic.ros_name}) is not in the recording: "
                "what it feeds stays without values",
            ))  # fmt: skip
            continue
        for connection in connections:
            if connection.msgtype != topic.message_type:
                found.problems.append((
                    topic.origin,
                    f"topic `{topic.name}` ({topic.ros_name}) is recorded as {connection.msgtype}, "
                    f"the spec reads {topic.message_type}: its messages are skipped",
                ))  # fmt: skip
                key = f"messages of another type: {topic.ros_name}"
                skipped = found.skipped_messages
                skipped[key] = skipped.get(key, 0) + connection.msgcount
                continue
            store = connection_store(reader, connection)
            missing = _undefined(store, connection.msgtype)
            if missing is not None:
                found.problems.append((
                    topic.origin,
                    f"topic `{topic.name}` ({topic.ros_name}): the recording holds no "
                    f"definition of {missing}, nor do ROS 2's types or the spec's: "
                    "its messages are skipped",
                ))  # fmt: skip
                key = f"messages without a definition: {topic.ros_name}"
                skipped = found.skipped_messages
                skipped[key] = skipped.get(key, 0) + connection.msgcount
                continue
            found.connections.append(connection)
            fields_of = lambda name, store=store: store.fielddefs[name][1]  # noqa: E731
            unread = definitions.problems(
                fields_of, connection.msgtype, variables.get(topic.name, []), topic.ros_name
            )
            for name, text in unread.items():
                if name not in found.skipped_variables:
                    found.skipped_variables.add(name)
                    found.problems.append((origins[name], text))
    return found


def open_reader(paths: Sequence[Path], spec: ir.Spec) -> Any:
    from rosbags.highlevel import AnyReader, AnyReaderError

    for path in paths:
        if not path.exists():
            raise ReplayError(f"{path}: no such file or directory")
    bags = [p for p in paths if p.suffix == ".bag"]
    if bags and len(bags) != len(paths):  # rosbags reads ROS 1 or rosbag2, not both
        other = next(p for p in paths if p.suffix != ".bag")
        raise ReplayError(f"{bags[0]} is a ROS 1 bag and {other} a rosbag2 recording: "
                          "they cannot be read as one; replay them without --merge")  # fmt: skip
    try:
        reader = AnyReader(list(paths), default_typestore=deferred_default_store(spec))
        reader.open()
        _fill_undefined(reader, spec)
    except AnyReaderError as error:
        raise ReplayError(
            f"{', '.join(map(str, paths))}: cannot read the recording: {_reader_words(error)}"
        ) from None
    except Exception as error:  # rosbags meets damaged bytes in many ways
        raise ReplayError(
            f"{', '.join(map(str, paths))}: cannot read the recording: {damage(error)}"
        ) from None
    return reader


def _reader_words(error: Exception) -> str:
    """rosbags' refusal, without the Python beneath it."""
    text = str(error)
    if text.startswith("Invalid bag metadata"):
        return "its metadata.yaml is damaged, or not a rosbag2 recording's"
    if text.startswith("Unrecognized storage format"):
        return "it is not a recording: rosbags reads ROS 1 .bag, and .db3 and .mcap of rosbag2"
    return text


def damage(error: Exception) -> str:
    """What a reader's error on damaged bytes means, in a user's words."""
    if isinstance(error, UnicodeDecodeError):
        return "it is damaged: it holds bytes that are not text where text belongs"
    if isinstance(error, OverflowError | IndexError | MemoryError | struct.error):
        return "it is damaged: a length or an offset in it points outside the file"
    if isinstance(error, OSError):
        return os_words(error)
    return str(error) or f"it is damaged ({type(error).__name__})"


def messages_in_order(
    reader: Any, connections: Sequence[Any], start: int | None, stop: int | None
) -> Iterator[tuple[Any, int, bytes]]:
    """The messages of `connections` (none: no message) in time order, those of
    one time in the order the recordings were given, then as each holds them.
    (rosbags' AnyReader orders one time's messages of several recordings by where
    its readers lie in memory, which differs from run to run; and reads every
    message when given no connection.)"""
    chosen = {id(c) for c in connections}
    # by the connection's owner (a recording's reader), in the reader's order of
    # connections: the recordings' own
    owners: dict[int, tuple[Any, list[Any]]] = {}
    for connection in reader.connections:
        if id(connection) in chosen:
            owner = connection.owner
            owners.setdefault(id(owner), (owner, []))[1].append(connection)
    generators = [
        owner.messages(connections=chosen_of, start=start, stop=stop)
        for owner, chosen_of in owners.values()
    ]
    return heapq.merge(*generators, key=lambda message: message[1])


def key(connection: Any) -> tuple[int, int]:
    """A connection among several recordings': each numbers its own from 0."""
    return connection.id, id(connection.owner)


def decoder(reader: Any, needs: dict[str, partial_decoding.Needs]) -> Callable[[Any, bytes], Any]:
    """How a connection's messages are decoded (`connection_readers`), as one
    function of the connection and the bytes."""
    reader_of = connection_readers(reader, needs)
    readers: dict[tuple[int, int], Callable[[bytes], Any]] = {}

    def decode(connection: Any, raw: bytes) -> Any:
        read = readers.get(key(connection))
        if read is None:
            read = readers[key(connection)] = reader_of(connection)
        return read(raw)

    return decode


def connection_readers(
    reader: Any, needs: dict[str, partial_decoding.Needs]
) -> Callable[[Any], Callable[[bytes], Any]]:
    """The decoder of a connection's messages: only the fields the spec reads of
    its topic (`needs`, rmvdsl.host.partial_decoding), by a reader compiled from
    the recording's definitions. ROS 1: by the live ROS 1 node's decoder
    (rmvdsl.host.ros1_decoding), from the connection's own definition and md5sum,
    so a bag and a live system are read alike, and two bags holding two versions
    of a type each with its own; ROS 2: from the connection's types (the reader's,
    or its own where they differ: typestores.connection_store)."""
    if reader.is2:
        return _refusing_if_unmade(_ros2_reader(reader, needs))
    from rmvdsl.host.ros1_decoding import Decoder

    ros1 = Decoder()

    def reader_of(connection: Any) -> Callable[[bytes], Any]:
        header = {
            "type": connection.msgtype, "md5sum": connection.digest,
            "message_definition": connection.msgdef.data,
        }  # fmt: skip
        return ros1.reader(header, needs.get(connection.topic))

    return _refusing_if_unmade(reader_of)


def _refusing_if_unmade(
    reader_of: Callable[[Any], Callable[[bytes], Any]],
) -> Callable[[Any], Callable[[bytes], Any]]:
    """`reader_of`, where a decoder that cannot be made refuses each message in
    the words of why (each is then reported damaged, as its decoding would be)."""

    def made(connection: Any) -> Callable[[bytes], Any]:
        try:
            return reader_of(connection)
        except Exception as error:
            words = str(error) or type(error).__name__

            def refuse(raw: bytes) -> Any:
                raise ValueError(words)

            return refuse

    return made


def _ros2_reader(
    reader: Any, needs: dict[str, partial_decoding.Needs]
) -> Callable[[Any], Callable[[bytes], Any]]:
    def reader_of(connection: Any) -> partial_decoding.Reader:
        store = shared_store(connection_store(reader, connection))
        topic, msgtype = connection.topic, connection.msgtype
        fields_of = lambda type_name: store.fielddefs[type_name][1]  # noqa: E731

        def full(raw: bytes | memoryview) -> Any:
            return store.deserialize_cdr(raw, msgtype)

        wanted = [needs[topic]] if topic in needs else []
        return partial_decoding.or_full(full, msgtype, wanted, fields_of, ros1=False)

    return reader_of


def window_time(text: str | None, start: int) -> int | None:
    """`--from`/`--to`: seconds on the recording's clock, or `+N` after its start."""
    if text is None:
        return None
    from fractions import Fraction

    relative = text.startswith("+")
    value = Fraction(text[1:] if relative else text)
    ns = int(value * 1_000_000_000)
    return start + ns if relative else ns
