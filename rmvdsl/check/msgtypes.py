"""ROS message definitions: rosbags' type stores and .msg files on a search path.

Standard packages come from the `rosbags` type store of the target distribution;
custom ones from `.msg` files, parsed here so that an error points at its own
file:line:column. Message names are kept in the ROS 2 form `pkg/msg/Type`.
"""

from __future__ import annotations

import contextlib
import os
import re
import threading
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from functools import cache
from typing import Any

from rmvdsl.lang import builtins
from rmvdsl.lang.diagnostics import Diagnostic, closest, error
from rmvdsl.lang.source import SourceFile, SourceMap, Span

ROS1_DISTROS = ("noetic", "melodic", "kinetic")
ROS2_DISTROS = ("dashing", "eloquent", "foxy", "galactic", "humble", "iron", "jazzy", "kilted")
DISTROS = ROS1_DISTROS + ROS2_DISTROS
DEFAULT_DISTRO = "jazzy"

INTEGERS = {
    "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "byte", "char",
}  # fmt: skip
FLOATS = {"float32", "float64"}
PRIMITIVES = INTEGERS | FLOATS | {"bool", "string", "wstring", "time", "duration"}
_FIELD_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_TYPE = re.compile(
    r"^(?P<base>[A-Za-z][A-Za-z0-9_]*(?:/[A-Za-z][A-Za-z0-9_]*){0,2})"
    r"(?P<string_bound><=\d+)?(?P<array>\[(?P<bound><=)?(?P<size>\d*)\])?$"
)


@dataclass(frozen=True)
class FieldType:
    """A field's type: a primitive or message name, possibly an array of it."""

    base: str  # a primitive (`float32`, `time`) or a message `pkg/msg/Type`
    array: bool = False
    size: int | None = None  # fixed size, or the bound of a bounded array
    bounded: bool = False

    @property
    def is_primitive(self) -> bool:
        return self.base in PRIMITIVES

    def element(self) -> FieldType:
        return FieldType(self.base)

    def text(self) -> str:
        if not self.array:
            return self.base
        size = "" if self.size is None else f"{'<=' if self.bounded else ''}{self.size}"
        return f"{self.base}[{size}]"


@dataclass
class MessageDef:
    name: str  # pkg/msg/Type
    fields: dict[str, FieldType]
    constants: dict[str, tuple[str, str]] = field(default_factory=dict)  # name -> (type, value)
    origin: str = ""  # a .msg path, or `rosbags:<store>`
    lines: dict[str, int] = field(default_factory=dict)  # field or constant -> its .msg line


def canonical(name: str, package: str | None = None) -> str:
    """`pkg/Type` and `pkg/msg/Type` as `pkg/msg/Type`; a bare `Type` in `package`."""
    parts = name.split("/")
    if len(parts) == 1:
        if name == "Header":
            return "std_msgs/msg/Header"
        return f"{package}/msg/{name}" if package else name
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name


def ros_version(distro: str) -> int:
    return 1 if distro in ROS1_DISTROS else 2


# ---- .msg files ----


def parse_msg(source: SourceFile, name: str) -> tuple[MessageDef | None, list[Diagnostic]]:
    """Parse a .msg file; every malformed line is an error at that line."""
    package = name.split("/")[0]
    fields: dict[str, FieldType] = {}
    constants: dict[str, tuple[str, str]] = {}
    diagnostics: list[Diagnostic] = []
    lines: dict[str, int] = {}
    for number in range(1, source.line_count + 1):
        line = source.line_text(number)
        known = len(fields), len(constants)
        problem = _parse_msg_line(line, package, fields, constants)
        for names, count in ((fields, known[0]), (constants, known[1])):
            if len(names) > count:
                lines[next(reversed(names))] = number
        if problem is not None:
            column, message, hint = problem
            start = source.offset(number, column)
            end = source.line_start(number) + len(line.rstrip())
            diagnostics.append(
                error(
                    "RMV304",
                    f"in message definition {name}: {message}",
                    source.span(start, max(end, start + 1)),
                    label="cannot read this line",
                    help=hint,
                )
            )
    if diagnostics:
        return None, diagnostics
    return MessageDef(name, fields, constants, source.path, lines), []


def _parse_msg_line(
    line: str,
    package: str,
    fields: dict[str, FieldType],
    constants: dict[str, tuple[str, str]],
) -> tuple[int, str, str | None] | None:
    code = _strip_comment(line)
    if not code.strip():
        return None
    indent = len(code) - len(code.lstrip())
    parts = code.split(None, 1)
    if len(parts) < 2:
        return indent + 1, f"`{code.strip()}` has a type but no field name", "write `TYPE NAME`"
    type_text, rest = parts
    match = _TYPE.match(type_text)
    if match is None:
        return indent + 1, f"`{type_text}` is not a type", "e.g. `float64`, `geometry_msgs/Point[]`"
    base = match.group("base")
    if base == "Header":
        base = "std_msgs/msg/Header"
    elif base not in PRIMITIVES:
        base = canonical(base, package)
    size_text = match.group("size")
    field_type = FieldType(
        base,
        array=match.group("array") is not None,
        size=int(size_text) if size_text else None,
        bounded=match.group("bound") is not None,
    )
    if "=" in rest and not rest.lstrip().startswith("="):
        constant, value = (piece.strip() for piece in rest.split("=", 1))
        if not _FIELD_NAME.match(constant):
            return line.find(constant) + 1, f"`{constant}` is not a constant name", None
        constants[constant] = (base, value)
        return None
    words = rest.split()
    field_name = words[0]
    if not _FIELD_NAME.match(field_name):
        return line.find(field_name) + 1, f"`{field_name}` is not a field name", None
    if field_name in fields:
        return line.find(field_name) + 1, f"field `{field_name}` is defined twice", None
    fields[field_name] = field_type
    return None


def _strip_comment(line: str) -> str:
    # `#` starts a comment, except inside the value of a string constant.
    if "=" in line.split("#", 1)[0] and line.split()[0].startswith("string"):
        return line
    return line.split("#", 1)[0]


def _msg_files(folder: str) -> Iterator[tuple[str, str]]:
    """(package, path) of the .msg files in a package's msg folder, a package
    folder, or a folder of packages."""
    folder = os.path.normpath(folder)
    try:
        entries = sorted(os.listdir(folder))
    except OSError:
        return
    # A ROS 2 install holds each message twice: X.msg and the X.idl generated from
    # it. The .msg is read; an .idl only where no .msg stands beside it.
    messages = {entry[:-4] for entry in entries if entry.endswith(".msg")}
    direct = [
        entry
        for entry in entries
        if entry.endswith(".msg") or (entry.endswith(".idl") and entry[:-4] not in messages)
    ]
    if direct:
        owner = os.path.dirname(folder) if os.path.basename(folder) == "msg" else folder
        package = os.path.basename(owner)
        for entry in direct:
            yield package, os.path.join(folder, entry)
        return
    if os.path.isdir(os.path.join(folder, "msg")):
        yield from _msg_files(os.path.join(folder, "msg"))
        return
    for entry in entries:
        msg_folder = os.path.join(folder, entry, "msg")
        if os.path.isdir(msg_folder):
            yield from _msg_files(msg_folder)


def environment_folders() -> list[str]:
    """The message folders of a sourced ROS workspace."""
    folders: list[str] = []
    # ROS 2's setup scripts set AMENT_PREFIX_PATH, ROS 1's (catkin) CMAKE_PREFIX_PATH:
    # each prefix holds its packages' messages under share/.
    for variable in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH"):
        for prefix in filter(None, os.environ.get(variable, "").split(os.pathsep)):
            share = os.path.join(prefix, "share")
            if os.path.isdir(share) and share not in folders:
                folders.append(share)
    folders.extend(
        p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if os.path.isdir(p)
    )
    return folders


# ---- rosbags type stores ----


@cache
def _store_definitions(distro: str) -> dict[str, MessageDef]:
    from rosbags.typesys import Stores, get_typestore
    from rosbags.typesys.base import Nodetype

    store = getattr(Stores, builtins.TYPE_STORES[distro])
    typestore = get_typestore(store)
    ros1 = ros_version(distro) == 1
    definitions = {}
    for name, (consts, fields) in typestore.fielddefs.items():
        converted = {}
        for field_name, (node_type, detail) in fields:
            converted[field_name] = _rosbags_type(node_type, detail, Nodetype, ros1)
        constants = {c_name: (str(c_type), repr(c_value)) for c_name, c_type, c_value in consts}
        definitions[name] = MessageDef(name, converted, constants, f"rosbags:{store.name}")
    if ros1:
        for builtin in ("builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"):
            definitions.pop(builtin, None)
    return definitions


def _rosbags_type(node_type: Any, detail: Any, nodetype: Any, ros1: bool) -> FieldType:
    if node_type == nodetype.BASE:
        return FieldType(str(detail[0]))
    if node_type == nodetype.NAME:
        return FieldType(_ros1_time(str(detail)) if ros1 else str(detail))
    element_detail, size = detail
    element = _rosbags_type(element_detail[0], element_detail[1], nodetype, ros1)
    if node_type == nodetype.ARRAY:
        return FieldType(element.base, array=True, size=int(size))
    return FieldType(element.base, array=True, size=int(size) or None, bounded=bool(size))


def _ros1_time(name: str) -> str:
    # rosbags stores ROS 1 `time`/`duration` as builtin_interfaces messages.
    return {
        "builtin_interfaces/msg/Time": "time",
        "builtin_interfaces/msg/Duration": "duration",
    }.get(name, name)


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

    @property
    def ros_version(self) -> int:
        return ros_version(self.distro)

    def get(self, name: str) -> MessageDef | None:
        full = canonical(name)
        return self.custom.get(full) or _store_definitions(self.distro).get(full)

    def names(self) -> Iterable[str]:
        yield from self.custom
        yield from _store_definitions(self.distro)

    def closest_type(self, name: str) -> str | None:
        full = canonical(name)
        if full not in self._closest:
            self._closest[full] = self._closest_uncached(full)
        return self._closest[full]

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
        for package, path in _listed_files(folder):
            name = f"{package}/msg/{os.path.splitext(os.path.basename(path))[0]}"
            if name in self.custom or name in self.broken:
                continue  # the first folder on the path wins, as in ROS
            read = _read_definitions(name, path, self.ros_version == 1)
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


@dataclass(frozen=True)
class _FileRead:
    source: SourceFile | None
    definitions: dict[str, MessageDef]
    diagnostics: tuple[Diagnostic, ...] = ()
    broken: bool = False


_FILES: dict[tuple[str, str, bool], tuple[tuple[int, int], _FileRead]] = {}
_LISTINGS: dict[str, tuple[tuple[tuple[str, int], ...], list[tuple[str, str]]]] = {}
_CACHE_LOCK = threading.Lock()


_ASKED: set[str] = set()


def folders_read() -> set[str]:
    """Every message folder asked for in this process, and every folder listed
    below one (a file added to or removed from one of them changes its mtime)."""
    with _CACHE_LOCK:
        listed = {d for stamps, _ in _LISTINGS.values() for d, _ in stamps}
        return _ASKED | listed


def _stamp(path: str) -> tuple[int, int]:
    try:
        status = os.stat(path)
    except OSError:
        return (-1, -1)
    return (status.st_mtime_ns, status.st_size)


def _read_definitions(name: str, path: str, ros1: bool) -> _FileRead:
    key, stamp = (path, name, ros1), _stamp(path)
    with _CACHE_LOCK:
        cached = _FILES.get(key)
    if cached is not None and cached[0] == stamp and stamp != (-1, -1):
        return cached[1]
    read = _read_idl(name, path, ros1) if path.endswith(".idl") else _read_msg(name, path)
    with _CACHE_LOCK:
        _FILES[key] = (stamp, read)
    return read


def _listed_files(folder: str) -> list[tuple[str, str]]:
    """`_msg_files(folder)`, listed again only when a folder it read changed."""
    with _CACHE_LOCK:
        cached = _LISTINGS.get(folder)
    if cached is not None and all(_stamp(d)[0] == mtime for d, mtime in cached[0]):
        return cached[1]
    files = list(_msg_files(folder))
    seen = {folder, *(os.path.dirname(path) for _, path in files)}
    with contextlib.suppress(OSError):
        seen |= {os.path.join(folder, entry) for entry in os.listdir(folder)}
    stamps = tuple((d, _stamp(d)[0]) for d in sorted(seen) if os.path.isdir(d))
    with _CACHE_LOCK:
        _LISTINGS[folder] = (stamps, files)
    return files


def _read_source(name: str, path: str) -> SourceFile | _FileRead:
    try:
        with open(path, encoding="utf-8") as handle:
            return SourceFile(path, handle.read())
    except (OSError, UnicodeDecodeError) as exc:
        source = SourceFile(path, "")
        why = f"cannot read message definition {name}: {exc}"
        problem = error("RMV304", why, source.span(0, 0))
        return _FileRead(source, {}, (problem,), broken=True)


def _read_msg(name: str, path: str) -> _FileRead:
    source = _read_source(name, path)
    if isinstance(source, _FileRead):
        return source
    definition, problems = parse_msg(source, name)
    if definition is None:
        return _FileRead(source, {}, tuple(problems), broken=True)
    return _FileRead(source, {name: definition}, tuple(problems))


_PREPROCESSOR = re.compile(r"(?m)^[ \t]*#.*$")


def _read_idl(name: str, path: str, ros1: bool) -> _FileRead:
    """A ROS 2 .idl file, read by rosbags; its errors come with an offset."""
    from rosbags.typesys import get_types_from_idl
    from rosbags.typesys.base import Nodetype

    source = _read_source(name, path)
    if isinstance(source, _FileRead):
        return source
    text = source.text
    try:
        # rosbags reads no preprocessor lines (`#include "pkg/msg/X.idl"`): the types
        # they name are found by name among the others. Blanked, not removed, so
        # the offsets of errors stay where they are.
        types = get_types_from_idl(_PREPROCESSOR.sub(lambda m: " " * len(m.group()), text))
    except Exception as exc:  # rosbags raises its TypesysError, with the offset in it
        lines = str(exc).splitlines()
        offset = int(lines[2]) if len(lines) > 2 and lines[2].strip().isdigit() else 0
        problem = error(
            "RMV304",
            f"in message definition {name}: the IDL does not parse",
            source.span(offset, min(offset + 1, len(text))),
            label="cannot read from here",
        )
        return _FileRead(source, {}, (problem,), broken=True)
    definitions = {}
    for type_name, (consts, fields) in types.items():
        converted = {f: _rosbags_type(kind, detail, Nodetype, ros1) for f, (kind, detail) in fields}
        constants = {c: (str(t), repr(v)) for c, t, v in consts}
        definitions[type_name] = MessageDef(type_name, converted, constants, path)
    return _FileRead(source, definitions)
