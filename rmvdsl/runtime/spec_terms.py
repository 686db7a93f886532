"""The resolved spec's leaves (docs/ir.md): value types, name patterns and
credentials, expressions, and actions. rmvdsl.runtime.spec holds the rest and
exports these too: read them as `spec.Number`, `spec.Log`."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import ClassVar

# ---- values ----

INTEGERS = frozenset({
    "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "byte", "char",
})  # fmt: skip
FLOATS = frozenset({"float32", "float64"})
# The kind of value (ValueType.kind) a field of each ROS type holds.
_KINDS = {
    "bool": "bool", **dict.fromkeys(INTEGERS, "int"), **dict.fromkeys(FLOATS, "float"),
    "string": "string", "wstring": "string",
    "time": "time", "builtin_interfaces/msg/Time": "time",
    "duration": "duration", "builtin_interfaces/msg/Duration": "duration",
}  # fmt: skip


def value_kind(ros_type: str) -> str | None:
    """The kind of value a field of `ros_type` holds (a primitive, or a time or a
    duration); None for any other message."""
    return _KINDS.get(ros_type)


@dataclass(frozen=True)
class ValueType:
    kind: str  # bool | int | float | string | time | duration
    ros: str = ""  # the ROS type it comes from, if any
    time_exponent: int = 0  # -1 per second (a derivative), +1 times seconds (an integral)


@dataclass(frozen=True)
class Pattern:
    """A ROS name pattern: `*` matches any run of characters."""

    text: str
    regex: str  # anchored, for Python's `re` and Go's RE2 alike


@dataclass(frozen=True)
class Credential:
    """A database credential: always from the environment (RMV211), or a username
    written in the spec."""

    env: str | None = None
    value: str | None = None


# ---- expressions ----


@dataclass(frozen=True)
class Number:
    TAG: ClassVar[str] = "number"
    text: str  # as written: `3` is an integer, `3.0` a float (InfluxQL's rule)
    value: Fraction
    type: ValueType


@dataclass(frozen=True)
class String:
    TAG: ClassVar[str] = "string"
    value: str
    type: ValueType


@dataclass(frozen=True)
class Boolean:
    TAG: ClassVar[str] = "bool"
    value: bool
    type: ValueType


@dataclass(frozen=True)
class Time:
    TAG: ClassVar[str] = "time"
    text: str
    seconds: Fraction
    type: ValueType


@dataclass(frozen=True)
class Ref:
    TAG: ClassVar[str] = "ref"
    name: str
    kind: str  # variable | event | emitted
    type: ValueType


@dataclass(frozen=True)
class Unary:
    TAG: ClassVar[str] = "unary"
    op: str  # `-` | `not`
    operand: Expr
    type: ValueType


@dataclass(frozen=True)
class Binary:
    TAG: ClassVar[str] = "binary"
    op: str  # InfluxQL's, with `<>` written `!=`
    left: Expr
    right: Expr
    type: ValueType


@dataclass(frozen=True)
class Call:
    TAG: ClassVar[str] = "call"
    function: str  # a name of rmvdsl.lang.builtins.FUNCTIONS
    args: tuple[Expr, ...]
    type: ValueType


Expr = Number | String | Boolean | Time | Ref | Unary | Binary | Call


# ---- actions ----


@dataclass(frozen=True)
class Log:
    TAG: ClassVar[str] = "log"
    message: str | None  # None: the owner's message
    level: str | None  # None: the alert's level (`error` outside alerts)


@dataclass(frozen=True)
class Publish:
    TAG: ClassVar[str] = "publish"
    topic: str
    message: str | None


@dataclass(frozen=True)
class Post:
    TAG: ClassVar[str] = "post"
    url: str
    timeout: Fraction


@dataclass(frozen=True)
class Exec:
    TAG: ClassVar[str] = "exec"
    command: str
    args: tuple[str, ...]


@dataclass(frozen=True)
class Tcp:
    TAG: ClassVar[str] = "tcp"
    address: str


Action = Log | Publish | Post | Exec | Tcp
