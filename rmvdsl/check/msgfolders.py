"""Message definitions read from folders of .msg and .idl files, each file read once
and cached by its modification time (a re-check reads only what changed)."""

from __future__ import annotations

import contextlib
import os
import re
import threading
from dataclasses import dataclass
from typing import Any

from rmvdsl.check.msgdefs import FieldType, MessageDef, msg_files, parse_msg
from rmvdsl.lang.diagnostics import Diagnostic, error
from rmvdsl.lang.source import SourceFile


def rosbags_type(node_type: Any, detail: Any, nodetype: Any, ros1: bool) -> FieldType:
    if node_type == nodetype.BASE:
        return FieldType(str(detail[0]))
    if node_type == nodetype.NAME:
        return FieldType(_ros1_time(str(detail)) if ros1 else str(detail))
    element_detail, size = detail
    element = rosbags_type(element_detail[0], element_detail[1], nodetype, ros1)
    if node_type == nodetype.ARRAY:
        return FieldType(element.base, array=True, size=int(size))
    return FieldType(element.base, array=True, size=int(size) or None, bounded=bool(size))


def _ros1_time(name: str) -> str:
    # rosbags stores ROS 1 `time`/`duration` as builtin_interfaces messages.
    return {
        "builtin_interfaces/msg/Time": "time",
        "builtin_interfaces/msg/Duration": "duration",
    }.get(name, name)


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


def read_definitions(name: str, path: str, ros1: bool) -> _FileRead:
    key, stamp = (path, name, ros1), _stamp(path)
    with _CACHE_LOCK:
        cached = _FILES.get(key)
    if cached is not None and cached[0] == stamp and stamp != (-1, -1):
        return cached[1]
    read = _read_idl(name, path, ros1) if path.endswith(".idl") else _read_msg(name, path)
    with _CACHE_LOCK:
        _FILES[key] = (stamp, read)
    return read


def listed_files(folder: str) -> list[tuple[str, str]]:
    """`msg_files(folder)`, listed again only when a folder it read changed."""
    with _CACHE_LOCK:
        cached = _LISTINGS.get(folder)
    if cached is not None and all(_stamp(d)[0] == mtime for d, mtime in cached[0]):
        return cached[1]
    files = list(msg_files(folder))
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
    from rosbags.interfaces import Nodetype
    from rosbags.typesys import get_types_from_idl

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
        converted = {f: rosbags_type(kind, detail, Nodetype, ros1) for f, (kind, detail) in fields}
        constants = {c: (str(t), repr(v)) for c, t, v in consts}
        definitions[type_name] = MessageDef(type_name, converted, constants, path)
    return _FileRead(source, definitions)
