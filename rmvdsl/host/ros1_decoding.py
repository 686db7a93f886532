"""ROS 1 messages as bytes, decoded with the definition their publisher sent.

A ROS 1 connection header carries the message's type, its md5sum and its full
definition (`message_definition`, nested types after `MSG:` lines): the node
subscribes with `rospy.AnyMsg` and decodes with rosbags from that text, so a type
such as `carla_msgs/CarlaEgoVehicleStatus` needs no generated Python message
installed (the thesis's type-agnostic subscription). The objects are the ones
`rmv replay` reads from a ROS 1 bag: the runtime reads both alike.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rmvdsl.host import definitions, partial_decoding
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import counted

Decode = Callable[[bytes], Any]


class DecodeError(Exception):
    """A message that cannot be decoded; the text says why."""


def missing() -> str | None:
    """What to tell the user when rosbags cannot be imported (None: it can). A node
    says it at start, not at its first message."""
    import importlib.util

    if importlib.util.find_spec("rosbags") is not None:
        return None
    return (
        "the ROS 1 nodes decode messages with rosbags, which this Python lacks: "
        "pip install rosbags (with Debian's ROS 1, in a venv made with "
        "--system-site-packages; docs/ros1.md)"
    )


def ros2_style(name: str) -> str:
    """`pkg/Type` as the resolved spec and rosbags name it: `pkg/msg/Type`."""
    package, _, type_name = name.partition("/")
    if not type_name or "/" in type_name:
        return name
    return f"{package}/msg/{type_name}"


class Decoder:
    """One decoder per (type, md5sum) a publisher announced, and per set of
    fields read: two publishers of one topic may send two versions of a type.
    Given what the spec reads of a topic (`needs`), only that is decoded
    (rmvdsl.host.partial_decoding); a message that reader refuses is decoded
    whole, which says what is wrong with it."""

    def __init__(self, optional: partial_decoding.Needs | None = None) -> None:
        self.decoders: dict[tuple[str, str, int], tuple[Any, Decode]] = {}
        # read too where the definition has it (the live node's `header.seq`)
        self.optional = optional
        self.problems: dict[tuple[str, str, str], dict[str, str]] = {}

    def message_type(self, header: Mapping[str, str]) -> str:
        return ros2_style(header.get("type", ""))

    def decode(
        self, header: Mapping[str, str], raw: bytes, needs: partial_decoding.Needs | None = None
    ) -> Any:
        return self.reader(header, needs)(raw)

    def reader(
        self, header: Mapping[str, str], needs: partial_decoding.Needs | None = None
    ) -> Decode:
        """`decode` of the messages a publisher with `header` sends, found once (a
        replay keeps it per connection)."""
        # a topic's needs are one long-lived dict: known by identity, not spelt out
        # at every message (and kept, so the identity stays its own)
        key = (header.get("type", ""), header.get("md5sum", ""), id(needs))
        found = self.decoders.get(key)
        if found is None or found[0] is not needs:
            try:
                definition = _definition(key[0], header)
                decode = _reader(key[0], definition, needs, self.optional)
            except DecodeError as error:  # once: every message of it fails alike
                decode = _refusing(error)
            found = self.decoders[key] = (needs, _said(key[0], decode))
        return found[1]

    def unread(
        self, header: Mapping[str, str], variables: Sequence[ir.Variable], ros_name: str
    ) -> dict[str, str]:
        """The variables (of one topic) that the publisher's definition does not give
        as the spec reads them, with the warning of each (rmvdsl.host.definitions):
        found once per definition and topic. A definition that does not parse gives
        none: each of its messages is reported damaged instead."""
        key = (header.get("type", ""), header.get("md5sum", ""), ros_name)
        found = self.problems.get(key)
        if found is None:
            try:
                store = _store(key[0], _definition(key[0], header))
            except DecodeError:
                found = {}
            else:
                fields_of = lambda name: store.fielddefs[name][1]  # noqa: E731
                source = "its publisher's definition"
                try:
                    found = definitions.problems(
                        fields_of, ros2_style(key[0]), variables, ros_name, source
                    )
                except KeyError:  # a type the definition names and does not define
                    found = {}
            self.problems[key] = found
        return found


def _reader(
    type_name: str,
    definition: str,
    needs: partial_decoding.Needs | None,
    optional: partial_decoding.Needs | None,
) -> Decode:
    store = _store(type_name, definition)
    name = ros2_style(type_name)
    deserialize = store.deserialize_ros1

    def full(raw: bytes | memoryview) -> Any:
        return deserialize(raw, name)

    fields_of = lambda type_name: store.fielddefs[type_name][1]  # noqa: E731
    if not needs:  # the whole message, by rosbags' decoder: guarded, as any
        return partial_decoding.guarded(full, name, fields_of)
    wanted = [partial_decoding.merged(needs, optional), needs] if optional else [needs]
    return partial_decoding.or_full(full, name, wanted, fields_of, ros1=True)


def _said(type_name: str, decode: Decode) -> Decode:
    """`decode`, with what rosbags raises (struct's and numpy's errors) said as a
    DecodeError naming the type and the message's size."""

    def read(raw: bytes) -> Any:
        try:
            return decode(raw)
        except DecodeError:
            raise
        except Exception as error:
            size = counted(len(raw), "byte")
            raise DecodeError(f"a {type_name} message of {size}: {error}") from None

    return read


def _refusing(error: DecodeError) -> Decode:
    def decode(raw: bytes) -> Any:
        raise error

    return decode


# The md5sum of a message of no fields (std_msgs/Empty's): ROS 1 hashes its
# definition's text, here nothing.
EMPTY_MD5 = "d41d8cd98f00b204e9800998ecf8427e"


def _definition(type_name: str, header: Mapping[str, str]) -> str:
    """The definition a connection header gives; an empty one only for a message
    of no fields, told by its md5sum (a publisher that sent none is refused)."""
    definition = header.get("message_definition", "")
    if not definition.strip() and header.get("md5sum") != EMPTY_MD5:
        raise DecodeError(f"the publisher of {type_name} sent no message definition")
    return definition


@functools.lru_cache(maxsize=256)
def _store(type_name: str, definition: str) -> Any:
    """The type store of `type_name` from its definition text, made once per
    process: a replay of many bags of one type, or a node whose publishers come
    and go, parses it once."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    name = ros2_style(type_name)
    try:
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(definition, name))
    except Exception as error:
        raise DecodeError(f"the definition of {type_name} does not parse: {error}") from None
    return store
