"""An installed ROS 2 message class's definition, in the form rosbags' type stores
give (`fields_of(name)`: each field with its Nodetype number and detail), so that
the monitor judges the class it subscribes with as the replay judges a recording
(rmvdsl.host.definitions): the spec's messages folder and the robot's installed
package can disagree, and a field the class holds as a string was read as a
number ("150" as 150) where the replay skips the variable.

rosidl's classes describe their fields in `SLOT_TYPES` (rosidl_parser.definition
objects), read here by their names and attributes: standard library only.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable
from typing import Any

from rmvdsl.host import definitions
from rmvdsl.host.wire_reader import ARRAY, BASE, NAME, PLACEHOLDER, SEQUENCE
from rmvdsl.runtime import spec as ir

# rosidl's basic type names -> rosbags' (ROS 2 .msg names; the integers are alike)
_BASIC = {
    "boolean": "bool", "octet": "byte", "char": "char", "wchar": "wchar",
    "float": "float32", "double": "float64", "long double": "float128",
}  # fmt: skip


def class_of(name: str) -> Any:
    """The rclpy class of `pkg/msg/Type` (or `pkg/Type`)."""
    parts = name.split("/")
    return getattr(importlib.import_module(f"{parts[0]}.msg"), parts[-1])


def fields_of(name: str) -> list[tuple[str, tuple[int, Any]]]:
    """The fields of the installed message `pkg/msg/Type`, as rosbags gives them."""
    cls = class_of(name)
    names = list(cls.get_fields_and_field_types())
    if not names:  # rosidl gives an empty message a member it does not list
        return [(PLACEHOLDER, (BASE, ("uint8", 0)))]
    return [(field, describe(slot)) for field, slot in zip(names, cls.SLOT_TYPES, strict=True)]


def unread(topic: ir.Topic, variables: Iterable[ir.Variable]) -> dict[str, str]:
    """The variables of `topic` its installed message class does not give as the
    spec reads them, with the warning of each (none where the class cannot be
    described: each message is then read as it comes)."""
    try:
        return definitions.problems(
            fields_of, topic.message_type, variables, topic.ros_name, "the installed definition"
        )
    except (ImportError, AttributeError, ValueError, TypeError):
        return {}


def describe(slot: Any) -> tuple[int, Any]:
    """One rosidl type as rosbags describes it: (BASE, (type, string bound)), (NAME,
    'pkg/msg/Type'), (ARRAY, (element, size)), (SEQUENCE, (element, bound))."""
    kind = type(slot).__name__
    if kind == "BasicType":
        return BASE, (_BASIC.get(slot.typename, slot.typename), 0)
    if kind in ("UnboundedString", "BoundedString", "UnboundedWString", "BoundedWString"):
        text = "wstring" if "WString" in kind else "string"
        return BASE, (text, getattr(slot, "maximum_size", 0))
    if kind == "NamespacedType":
        return NAME, "/".join([*slot.namespaces, slot.name])
    if kind == "Array":
        return ARRAY, (describe(slot.value_type), slot.size)
    if kind in ("BoundedSequence", "UnboundedSequence"):
        return SEQUENCE, (describe(slot.value_type), getattr(slot, "maximum_size", 0))
    raise ValueError(f"a field of rosidl type {kind}")
