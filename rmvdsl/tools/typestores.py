"""rosbags' type stores for replay, made once per process for each set of
definitions. Every recording opened builds its own store (its definitions parsed,
their classes made, their digests checked) and the store compiles a deserializer
for each type on its first message: for a fleet of small recordings that was half
of the replay's time (200 recordings of 40 messages: 10.6 s, compiling 52% of it).
A recording whose definitions were read before decodes with that store.
"""

from __future__ import annotations

import functools
import hashlib
import threading
from collections import OrderedDict
from typing import Any

from rmvdsl.lang import builtins
from rmvdsl.runtime import spec as ir

KEPT = 64  # stores of distinct definitions kept: memory stays flat on any fleet

_LOCK = threading.Lock()
_SHARED: OrderedDict[str, Any] = OrderedDict()
_DEFAULTS: OrderedDict[tuple[str, tuple[str, ...]], Any] = OrderedDict()


def default_store(spec: ir.Spec) -> Any:
    """The types of a recording without definitions of its own, plus every
    definition the spec resolved that they lack (custom messages). Only rosbag2
    recorded none (before Iron); a ROS 1 bag always holds them. So these are ROS
    2's types: the spec's distribution's, or Humble's for a ROS 1 spec (whose
    `std_msgs/Header`, with `seq`, would misread every ROS 2 message)."""
    name = builtins.TYPE_STORES.get(spec.ros.distro, "")
    if not name.startswith("ROS2_"):
        name = "ROS2_HUMBLE"
    texts = tuple(f"{m.name}\n{message_text(m)}" for m in spec.messages)
    return _kept(_DEFAULTS, (name, texts), lambda: _made(name, spec))


def deferred_default_store(spec: ir.Spec) -> Any:
    """`default_store(spec)`, made only when a recording turns out to have no
    definitions of its own (rosbags then reads the store's `fielddefs`): ROS 1
    bags and most rosbag2 recordings carry theirs, and making ROS 2 Humble's
    store was 75 ms of CPU at every replay's start, beside 28 ms for opening the
    recording."""
    return _Deferred(lambda: default_store(spec))


class _Deferred:
    """A store made on first use; anything asked of it is asked of the store."""

    def __init__(self, make: Any) -> None:
        self._make = make

    def __bool__(self) -> bool:  # rosbags asks whether there is a default store
        return True

    def __getattr__(self, name: str) -> Any:
        return getattr(self._make(), name)


def connection_store(reader: Any, connection: Any) -> Any:
    """The types that read `connection`'s messages: the reader's, unless the
    connection's own definitions differ from them. Recordings read together
    (`rmv replay --merge`) may hold two versions of a type, and rosbags keeps the
    one it read last: the older recording's messages were decoded with the newer
    definition (damaged, or misread where the sizes agree). Such a connection
    gets the reader's types with its own in their place, one store per
    definition, made once per process."""
    own = _own_types(connection.msgtype, connection.msgdef.format.name, connection.msgdef.data)
    store = reader.typestore
    if all(store.fielddefs.get(name) == fields for name, fields in own):
        return store
    text = f"{own!r} over {sorted(store.fielddefs.items())!r}"
    return _kept(_SHARED, hashlib.sha256(text.encode()).hexdigest(), lambda: _replaced(store, own))


@functools.lru_cache(maxsize=256)
def _own_types(msgtype: str, form: str, data: str) -> tuple[tuple[str, Any], ...]:
    """The types a connection's definition text gives (as rosbags' AnyReader parses
    it), by name; none where it has no text or it does not parse. Parsed once per
    process for each text (the plan and the decoder both ask)."""
    from rosbags.typesys import get_types_from_idl, get_types_from_msg

    found: dict[str, Any] = {}
    try:
        if form == "MSG":
            found.update(get_types_from_msg(data, msgtype))
        elif form == "IDL" and data.startswith(f"{_IDL_SEPARATOR}IDL: "):
            for section in data.split(_IDL_SEPARATOR)[1:]:
                found.update(get_types_from_idl(section.split("\n", 1)[1]))
        elif form == "IDL":
            found.update(get_types_from_idl(data))
    except Exception:  # rosbags read the recording's types already; keep those
        return ()
    return tuple(sorted(found.items()))


_IDL_SEPARATOR = "=" * 80 + "\n"  # rosbag2's, between several IDL texts


def _replaced(store: Any, own: tuple[tuple[str, Any], ...]) -> Any:
    from rosbags.typesys import Stores, get_typestore

    made = get_typestore(Stores.EMPTY)
    made.register({**store.fielddefs, **dict(own)})
    return made


def shared_store(store: Any) -> Any:
    """`store`, or a store of the same definitions made before (whose
    deserializers are compiled already). Keyed by the definitions themselves, so
    two versions of a type are two stores."""
    text = repr(sorted(store.fielddefs.items()))
    return _kept(_SHARED, hashlib.sha256(text.encode()).hexdigest(), lambda: store)


def message_text(message: ir.Message) -> str:
    return "\n".join(f"{f.type} {f.name}" for f in message.fields) + "\n"


def _made(name: str, spec: ir.Spec) -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(getattr(Stores, name))
    for message in spec.messages:
        if message.name not in store.fielddefs:
            try:
                store.register(get_types_from_msg(message_text(message), message.name))
            except Exception:
                continue
    return store


def _kept(stores: OrderedDict[Any, Any], key: Any, make: Any) -> Any:
    with _LOCK:
        found = stores.get(key)
        if found is not None:
            stores.move_to_end(key)
            return found
    made = make()
    with _LOCK:
        found = stores.setdefault(key, made)
        stores.move_to_end(key)
        while len(stores) > KEPT:
            stores.popitem(last=False)
    return found
