"""Whether a message definition gives the spec's variables as the spec reads them:
the one judgement of a recording's connection (`rmv replay`) and of a live ROS 1
publisher's connection header (the nodes decode with the definition the publisher
sent). A variable whose path the definition lacks, or whose field it declares of
another kind, is not read at all, with a warning at the variable's declaration
(docs/replay.md, "Before the first message"; docs/ros1.md, "Any message type").

`fields_of(type name)` gives a type's fields as rosbags' type stores hold them
(`store.fielddefs[name][1]`; kinds as rosbags.interfaces.Nodetype numbers them).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from rmvdsl.host.wire_reader import ARRAY, BASE, NAME, SEQUENCE
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.spec_terms import value_kind

FieldsOf = Callable[[str], Any]

# The runtime converts a field to the variable's kind (rmvdsl.runtime.fields): a
# number of another width reads alike, and so does an integer read as a float or
# a bool (ROS 1's bool is a uint8); but a string read as a bool is true whatever
# it says, and a float read as an int is cut. (The spec's kind, the definition's)
# that read alike besides each kind with itself:
_ALIKE = {("float", "int"), ("bool", "int"), ("int", "bool")}


def problems(
    fields_of: FieldsOf,
    msgtype: str,
    variables: Iterable[ir.Variable],
    ros_name: str,
    source: str = "the recording",
) -> dict[str, str]:
    """Each variable the definition of `msgtype` does not give, with the warning
    that says why (by the variable's name); `source` names where the definition
    comes from."""
    found = {}
    for variable in variables:
        problem = path_problem(fields_of, msgtype, variable, source)
        if problem is not None:
            found[variable.name] = f"variable `{variable.name}` on {ros_name}: {problem}"
    return found


def path_problem(
    fields_of: FieldsOf, msgtype: str, variable: ir.Variable, source: str = "the recording"
) -> str | None:
    """Whether the definition of `msgtype` has the variable's path, down to a field
    of a kind the spec reads alike (None), or what differs."""
    current: Any = (NAME, msgtype)
    where = msgtype
    for step in variable.path:
        kind, detail = current
        if isinstance(step, ir.FieldStep):
            if kind != NAME:
                return f"`{where}` is not a message, so it has no field `{step.name}`"
            fields = dict(fields_of(detail))
            if step.read not in fields:
                return f"{detail} has no field `{step.read}` (it has {', '.join(fields)})"
            current, where = fields[step.read], f"{where}.{step.read}"
        else:
            if kind not in (ARRAY, SEQUENCE):
                return f"`{where}` is not an array"
            current = detail[0]
    return _leaf_problem(current, variable, where, source)


def _family(type_name: str) -> str:
    """A type's kind of value (ValueType.kind), or the type itself (a message)."""
    base = type_name.split("[")[0].split("<")[0]
    return value_kind(base) or base


def _leaf_problem(leaf: Any, variable: ir.Variable, where: str, source: str) -> str | None:
    """Whether the definition's type of what the path reads is one the spec's reads
    alike (None), or what differs."""
    kind, detail = leaf
    step = next((s for s in reversed(variable.path) if isinstance(s, ir.FieldStep)), None)
    if step is None or kind not in (BASE, NAME):
        return None
    recorded = detail[0] if kind == BASE else detail
    expected = step.type.split("[")[0]
    families = (_family(expected), _family(recorded))
    if families[0] == families[1] or families in _ALIKE:
        return None
    return f"`{where}` is {recorded} in {source}, the spec reads {expected}"
