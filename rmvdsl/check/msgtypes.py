"""ROS message definitions: rosbags' type stores and .msg files on a search path.

Standard packages come from the `rosbags` type store of the target distribution;
custom ones from `.msg` files, parsed here so that an error points at its own
file:line:column. Message names are kept in the ROS 2 form `pkg/msg/Type`.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cache
from typing import Any

from rmvdsl.check.msgdefs import FieldType, MessageDef, canonical
from rmvdsl.check.msgfolders import (
    _ASKED,
    _CACHE_LOCK,
    listed_files,
    read_definitions,
    rosbags_type,
)
from rmvdsl.lang import builtins
from rmvdsl.lang.diagnostics import Diagnostic, closest, error
from rmvdsl.lang.source import SourceMap, Span
from rmvdsl.util.bounded import Bounded
from rmvdsl.util.cache import Cache, digest
from rmvdsl.util.folders import cache_folder

ROS1_DISTROS = ("noetic", "melodic", "kinetic")
ROS2_DISTROS = ("dashing", "eloquent", "foxy", "galactic", "humble", "iron", "jazzy", "kilted")
DISTROS = ROS1_DISTROS + ROS2_DISTROS
DEFAULT_DISTRO = "jazzy"


def ros_version(distro: str) -> int:
    return 1 if distro in ROS1_DISTROS else 2


# ---- .msg files ----


# ---- rosbags type stores ----


# Bump when what is kept of a store's definitions changes.
STORE_FORMAT = 1


@cache
def _store_definitions(distro: str) -> dict[str, MessageDef]:
    """The distribution's standard messages. rosbags builds its store in 120-210 ms
    (a class for each of its 162 types), which every new process paid for a spec
    using one of them; they are kept in the cache folder as JSON, by the store
    module's size and modification time, and read back in a few milliseconds."""
    store_name = builtins.TYPE_STORES[distro]
    key = _store_key(store_name, ros_version(distro) == 1)
    kept = None if key is None else _kept_stores().get(key)
    if kept is not None:
        with contextlib.suppress(AttributeError, KeyError, TypeError, ValueError):
            return _from_json(kept)  # else a damaged file: read the store again
    definitions = _read_store(distro, store_name)
    if key is not None:
        _kept_stores().put(key, _as_json(definitions))
    return definitions


def _store_key(store_name: str, ros1: bool) -> str | None:
    """The key of a store's definitions: its module file's path, size and time
    (found without importing rosbags); None where the file is not found."""
    found = importlib.util.find_spec("rosbags")
    for folder in (found.submodule_search_locations or []) if found else []:
        path = os.path.join(folder, "typesys", "stores", store_name.lower() + ".py")
        with contextlib.suppress(OSError):
            stat = os.stat(path)
            return digest("store", STORE_FORMAT, path, stat.st_size, stat.st_mtime_ns, ros1)
    return None


def _kept_stores() -> Cache:
    folder = cache_folder()
    return Cache(os.path.join(folder, "stores") if folder else None)


def _as_json(definitions: dict[str, MessageDef]) -> dict[str, Any]:
    return {
        name: {
            "fields": {f: [t.base, t.array, t.size, t.bounded] for f, t in d.fields.items()},
            "constants": d.constants,
            "origin": d.origin,
        }
        for name, d in definitions.items()
    }


def _from_json(kept: dict[str, Any]) -> dict[str, MessageDef]:
    return {
        name: MessageDef(
            name,
            {f: _field_type(*kept_type) for f, kept_type in d["fields"].items()},
            {c: (str(kind), str(value)) for c, (kind, value) in d["constants"].items()},
            str(d["origin"]),
        )
        for name, d in kept.items()
    }


def _field_type(base: str, array: bool, size: int | None, bounded: bool) -> FieldType:
    return FieldType(str(base), bool(array), None if size is None else int(size), bool(bounded))


def _read_store(distro: str, store_name: str) -> dict[str, MessageDef]:
    from rosbags.interfaces import Nodetype
    from rosbags.typesys import Stores, get_typestore

    store = getattr(Stores, store_name)
    typestore = get_typestore(store)
    ros1 = ros_version(distro) == 1
    definitions = {}
    for name, (consts, fields) in typestore.fielddefs.items():
        converted = {}
        for field_name, (node_type, detail) in fields:
            converted[field_name] = rosbags_type(node_type, detail, Nodetype, ros1)
        constants = {c_name: (str(c_type), repr(c_value)) for c_name, c_type, c_value in consts}
        definitions[name] = MessageDef(name, converted, constants, f"rosbags:{store.name}")
    if ros1:
        for builtin in ("builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"):
            definitions.pop(builtin, None)
    return definitions


@cache
def _store_packages(distro: str) -> frozenset[str]:
    return frozenset(name.split("/")[0] for name in _store_definitions(distro))


# did-you-mean answers by (distro, custom types, name), kept across checks
_SUGGESTED: Bounded[tuple[str, frozenset[str], str], tuple[str | None]] = Bounded(4096)


# ---- the registry ----


@dataclass
class TypeRegistry:
    distro: str
    custom: dict[str, MessageDef] = field(default_factory=dict)
    broken: set[str] = field(default_factory=set)  # .msg files that did not parse
    diagnostics: list[Diagnostic] = field(default_factory=list)
    sources: SourceMap = field(default_factory=SourceMap)
    # did-you-mean answers by type name: 1,000 topics of one unknown type ask once
    _closest: dict[str, str | None] = field(default_factory=dict, repr=False)
    # each name's definition as asked for: a keystroke's check asks for every
    # variable's messages again (to see they are the ones its memo read)
    _got: dict[str, MessageDef | None] = field(default_factory=dict, repr=False)

    @property
    def ros_version(self) -> int:
        return ros_version(self.distro)

    def get(self, name: str) -> MessageDef | None:
        if name in self._got:
            return self._got[name]
        full = canonical(name)
        found = self.custom.get(full) or _store_definitions(self.distro).get(full)
        self._got[name] = found
        return found

    def names(self) -> Iterable[str]:
        yield from self.custom
        yield from _store_definitions(self.distro)

    def closest_type(self, name: str) -> str | None:
        full = canonical(name)
        if full not in self._closest:
            # and across checks: an editor re-checks a spec of unknown types at
            # every keystroke (50 of them asked 13 ms of a 48 ms check)
            key = (self.distro, frozenset(self.custom), full)
            found = _SUGGESTED.get(key)
            if found is None:
                found = (self._closest_uncached(full),)
                _SUGGESTED.put(key, found)
            self._closest[full] = found[0]
        return self._closest[full]

    def has_package(self, package: str) -> bool:
        """Whether any type known is of `package`."""
        prefix = package + "/"
        return package in _store_packages(self.distro) or any(
            n.startswith(prefix) for n in self.custom
        )

    def _closest_uncached(self, full: str) -> str | None:
        names = list(self.names())
        package = full.split("/")[0]
        type_name = full.split("/")[-1]
        same_package = [n for n in names if n.startswith(package + "/")]
        best = closest(full, same_package) if same_package else None
        if best is None:
            by_type = {n.split("/")[-1]: n for n in names}
            guess = closest(type_name, by_type) if type_name not in by_type else type_name
            best = by_type.get(guess) if guess else None
        return best

    def time_fields(self, base: str) -> dict[str, FieldType]:
        """The fields of ROS 1 `time` and `duration`."""
        kind = "uint32" if base == "time" else "int32"
        return {"secs": FieldType(kind), "nsecs": FieldType(kind)}

    def add_folder(self, folder: str, declared_at: Span | None = None) -> None:
        self._closest.clear()  # new types: other answers
        self._got.clear()
        with _CACHE_LOCK:
            _ASKED.add(folder)
        if not os.path.isdir(folder):
            if declared_at is not None:
                self.diagnostics.append(
                    error(
                        "RMV306",
                        f"message folder `{folder}` does not exist",
                        declared_at,
                        label="no such folder",
                        help="paths are relative to the spec's folder",
                    )
                )
            return
        for package, path in listed_files(folder):
            name = f"{package}/msg/{os.path.splitext(os.path.basename(path))[0]}"
            if name in self.custom or name in self.broken:
                continue  # the first folder on the path wins, as in ROS
            read = read_definitions(name, path, self.ros_version == 1)
            if read.source is not None:
                self.sources.add(read.source)
            self.diagnostics.extend(read.diagnostics)
            if read.broken:
                self.broken.add(name)
            for type_name, definition in read.definitions.items():
                self.custom.setdefault(type_name, definition)


# ---- reading folders, cached by modification time ----
# An editor checks at every keystroke; a sourced ROS workspace holds hundreds of
# packages. Files are parsed again only when their size or modification time
# changed, folders listed again only when one of them changed.
