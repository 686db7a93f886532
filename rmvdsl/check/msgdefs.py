"""Message definitions: a field's type, a message's fields, canonical type names, and
reading a .msg file (its diagnostics with file:line:column) or a folder of them."""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from dataclasses import dataclass, field

from rmvdsl.lang.diagnostics import Diagnostic, error
from rmvdsl.lang.source import SourceFile
from rmvdsl.runtime.spec_terms import FLOATS, INTEGERS

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


def msg_files(folder: str) -> Iterator[tuple[str, str]]:
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
        yield from msg_files(os.path.join(folder, "msg"))
        return
    for entry in entries:
        msg_folder = os.path.join(folder, entry, "msg")
        if os.path.isdir(msg_folder):
            yield from msg_files(msg_folder)


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
