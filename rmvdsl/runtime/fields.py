"""Variables: the value a resolved variable reads from one decoded message
(docs/runtime.md, "Variables"). Standard library only.

A decoded message is nested objects with attributes (rosbags, rclpy) or nested
mappings (JSON); arrays are any sequence (lists, tuples, numpy arrays). The path's
steps come typed from the resolved spec: a field, an index, or `[*]` (every
element, reduced by the variable's aggregate).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterable, Mapping, Sequence
from fractions import Fraction
from typing import Any

from rmvdsl.runtime.spec import EachStep, FieldStep, IndexStep, Topic, Variable
from rmvdsl.runtime.values import INT_MAX, INT_MIN, wrap
from rmvdsl.runtime.wording import counted


class Missing:
    """No value: an index past the end of an array, or an aggregate that needs at
    least one element (`min`, `max`, `mean`) over none. The message gives the
    variable no sample; the runtime counts it."""

    _instance: Missing | None = None

    def __new__(cls) -> Missing:
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "MISSING"


MISSING = Missing()


class FieldError(ValueError):
    """The message does not have the shape the spec's types say (a field absent,
    an array where a value was expected): the recording and the spec disagree."""


def _int(value: Any) -> int:
    """An integer as the runtime holds it: int64, so a uint64 above 2^63 - 1 wraps
    to a negative number, as InfluxDB stores it (docs/runtime.md, "Values")."""
    number = int(value)
    return number if INT_MIN <= number <= INT_MAX else wrap(number)


_SCALARS: dict[str, Any] = {"bool": bool, "int": _int, "float": float}
_PLAIN = frozenset({bool, int, float})


def reader(variable: Variable) -> Any:
    """`read` for one variable, with a fast path for the common shape: fields only,
    down to a number or a bool, on objects with attributes. Anything else (a
    mapping, a missing field, an array) takes `read`, which says what is wrong."""
    if variable.aggregate is not None:
        return _aggregate_reader(variable)
    convert = _SCALARS.get(variable.type.kind)
    if convert is None or not all(isinstance(step, FieldStep) for step in variable.path):
        return lambda message: read(variable, message)
    names = tuple(step.read for step in variable.path if isinstance(step, FieldStep))
    if not names:
        return lambda message: read(variable, message)
    walk = operator.attrgetter(".".join(names))  # the path's getattr calls, in C

    def fast(message: Any) -> Any:
        try:
            value = walk(message)
            if type(value) in _PLAIN:
                return convert(value)
            return read(variable, message)  # numpy scalars, arrays: the careful way
        except (AttributeError, TypeError, ValueError):
            return read(variable, message)

    return fast


def _aggregate_reader(variable: Variable) -> Any:
    """`read` for an array aggregate (`max(objects[*].twist.linear.x)`), with a
    fast path for attribute objects and lists or tuples of them down to numbers or
    bools: the elements' values converted as `read` converts them, then the
    aggregate. Anything else (a mapping, a numpy array, an index, a value of
    another type) takes `read`."""
    convert = _SCALARS.get(_element_kind(variable))
    steps = variable.path
    if convert is None or not all(isinstance(s, FieldStep | EachStep) for s in steps):
        return lambda message: read(variable, message)
    plan = tuple(step.read if isinstance(step, FieldStep) else None for step in steps)
    walk = _walker(plan)
    name = variable.aggregate
    assert name is not None

    def fast(message: Any) -> Any:
        values = None if _is_mapping(type(message)) else walk(message)
        if values is None or not _PLAIN.issuperset(map(type, values)):
            return read(variable, message)  # numpy, mappings, methods: the careful way
        try:
            converted = list(map(convert, values))
        except (ValueError, OverflowError):  # NaN or infinity as an integer
            return read(variable, message)  # which says so
        return aggregate(name, converted)

    return fast


def _walker(plan: tuple[str | None, ...]) -> Callable[[Any], list[Any] | None]:
    """`_walk` of `plan`; for a path through one array (`objects[*].twist.linear.x`,
    `ranges[*]`) its getattr calls made by operator.attrgetter, in C."""
    if plan.count(None) != 1:
        return lambda message: _walk(plan, message)
    split = plan.index(None)
    before = ".".join(name for name in plan[:split] if name is not None)
    after = ".".join(name for name in plan[split + 1 :] if name is not None)
    head = operator.attrgetter(before) if before else None
    tail = operator.attrgetter(after) if after else None

    def walk(message: Any) -> list[Any] | None:
        try:
            elements = message if head is None else head(message)
            if type(elements) is not list and type(elements) is not tuple:
                return None
            return list(elements) if tail is None else list(map(tail, elements))
        except AttributeError:
            return None

    return walk


def _walk(plan: tuple[str | None, ...], message: Any) -> list[Any] | None:
    """The values at the end of a path of attributes (a name) and every element
    of a list or tuple (None); None where the message is not so shaped."""
    values = [message]
    for field in plan:
        if field is not None:
            try:
                values = [getattr(value, field) for value in values]
            except AttributeError:
                return None
            continue
        elements: list[Any] = []
        for value in values:
            if type(value) is not list and type(value) is not tuple:
                return None
            elements.extend(value)
        values = elements
    return values


def read(variable: Variable, message: Any) -> Any:
    """The variable's value in the message, as a Python bool, int, float, str, or
    exact seconds (a Fraction) for times and durations; MISSING when there is none."""
    values: list[Any] = [message]
    fanned = False
    for step in variable.path:
        if isinstance(step, FieldStep):
            values = [_field(v, step) for v in values]
        elif isinstance(step, IndexStep):
            values = [_element(v, step.index) for v in values]
            values = [v for v in values if v is not MISSING]
            if not values:
                return MISSING
        elif isinstance(step, EachStep):
            values = [item for v in values for item in _sequence(v, variable.name)]
            fanned = True
    kind = variable.type.kind if variable.aggregate is None else _element_kind(variable)
    converted = [_convert(v, kind, variable.name) for v in values]
    if variable.aggregate is not None:
        return aggregate(variable.aggregate, converted)
    if fanned or len(converted) != 1:
        raise FieldError(f"`{variable.name}` reads {counted(len(converted), 'value')}, not one")
    return converted[0]


def aggregate(name: str, values: Sequence[Any]) -> Any:
    """An array aggregate (rmvdsl.lang.builtins.ARRAY_AGGREGATES, and `number`). A NaN
    element is no reading (a laser's missed return): `min`, `max`, `sum` and `mean`
    skip it, as numpy's `nanmin` and InfluxDB do, and none depends on the order of
    the elements."""
    if name == "number":
        return 1 if values[0] else 0
    if name == "count":
        return len(values)
    if name == "any":
        return any(values)
    if name == "all":
        return all(values)
    numbers = [v for v in values if v == v]  # NaN is the one value unequal to itself
    if name == "sum":
        return _sum(numbers)
    if not numbers:
        return MISSING
    if name == "min":
        least = min(numbers)
        return min(_zeros(numbers), key=_order) if least == 0 and _floats(numbers) else least
    if name == "max":
        most = max(numbers)
        return max(_zeros(numbers), key=_order) if most == 0 and _floats(numbers) else most
    if name == "mean":  # integers: their exact sum, divided once; floats: fsum's
        total = _sum(numbers) if _floats(numbers) else sum(numbers)
        return total / len(numbers)
    raise ValueError(f"unknown array aggregate {name!r}")


def _floats(numbers: Sequence[Any]) -> bool:
    return any(type(v) is float for v in numbers)


def _zeros(numbers: Sequence[Any]) -> list[Any]:
    """The zeros among `numbers`: the one place `min` and `max` must tell numbers
    equal in value apart (elsewhere the first of equal ones is the one `_order`
    picks too)."""
    return [v for v in numbers if v == 0]


def _order(value: Any) -> tuple[float, float]:
    """-0.0 before 0.0: equal numbers, but which one `min` returns must not depend
    on which came first."""
    return (value, math.copysign(1.0, value))


def _sum(numbers: Sequence[Any]) -> Any:
    """Integers wrap at 64 bits (any order gives the same); floats are summed exactly
    and rounded once (`math.fsum`), so the order does not change the last digit."""
    if not _floats(numbers):
        return wrap(sum(numbers))
    floats = [float(v) for v in numbers]
    infinite = {v for v in floats if math.isinf(v)}
    if infinite:
        return math.nan if len(infinite) == 2 else infinite.pop()
    try:
        return math.fsum(floats)
    except OverflowError:
        return math.copysign(math.inf, sum(floats))


def _field(value: Any, step: FieldStep) -> Any:
    if _is_mapping(type(value)):
        if step.read in value:
            return value[step.read]
        if step.name in value:
            return value[step.name]
    else:
        for name in (step.read, step.name):
            if hasattr(value, name):
                return getattr(value, name)
    raise FieldError(f"the message has no field `{step.name}` ({step.type})")


def _is_mapping(kind: type) -> bool:
    """`isinstance(value, Mapping)` by the value's class, remembered: the ABC's
    check costs more than reading the field (a decoded message's classes are few)."""
    known = _MAPPINGS.get(kind)
    if known is None:
        known = issubclass(kind, Mapping)
        if len(_MAPPINGS) < 4096:
            _MAPPINGS[kind] = known
    return known


_MAPPINGS: dict[type, bool] = {dict: True}


def _element(value: Any, index: int) -> Any:
    items = _sequence(value, f"[{index}]")
    return items[index] if index < len(items) else MISSING


def _sequence(value: Any, what: str) -> Sequence[Any]:
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Iterable):
        raise FieldError(f"{what}: expected an array, found {type(value).__name__}")
    return value if isinstance(value, Sequence) else list(value)


def _element_kind(variable: Variable) -> str:
    step = next((s for s in reversed(variable.path) if isinstance(s, FieldStep)), None)
    base = step.type.split("[")[0] if step else ""
    if base == "bool" or variable.aggregate == "number":
        return "bool"
    if base in ("float32", "float64"):
        return "float"
    if base in ("time", "duration", "builtin_interfaces/msg/Time"):
        return "time"
    return "int" if base else variable.type.kind


def _convert(value: Any, kind: str, name: str) -> Any:
    try:
        if kind == "bool":
            return bool(value)
        if kind == "int":
            return _int(value)
        if kind == "float":
            return float(value)
        if kind == "string":
            return value if isinstance(value, str) else bytes(value).decode("utf-8", "replace")
        if kind in ("time", "duration"):
            return _seconds(value)
    except (TypeError, ValueError, OverflowError) as exc:  # inf is no integer
        raise FieldError(f"`{name}`: {exc}") from None
    return value


def _seconds(value: Any) -> Fraction:
    """A ROS time or duration (`sec`/`nanosec`, or ROS 1's `secs`/`nsecs`) in exact
    seconds."""
    if isinstance(value, Mapping):
        parts = dict(value)
    else:
        names = ("sec", "nanosec", "secs", "nsecs")
        parts = {n: getattr(value, n) for n in names if hasattr(value, n)}
    seconds = parts.get("sec", parts.get("secs"))
    nanoseconds = parts.get("nanosec", parts.get("nsecs"))
    if seconds is None or nanoseconds is None:
        raise TypeError(f"not a ROS time: {type(value).__name__}")
    return Fraction(int(seconds)) + Fraction(int(nanoseconds), 10**9)


def stamped_topics(topics: Iterable[Topic]) -> frozenset[str]:
    """The ROS names of the topics whose messages take their time from their
    `header.stamp` (`time = header`); the others take the time they arrive."""
    return frozenset(t.ros_name for t in topics if t.time_source == "header")


def stamp(message: Any) -> int:
    """The message's `header.stamp` in integer nanoseconds (a topic with
    `time = header`)."""
    header = _field(message, FieldStep("header", "header", "std_msgs/msg/Header"))
    value = _field(header, FieldStep("stamp", "stamp", "time"))
    try:
        return int(_seconds(value) * 1_000_000_000)
    except TypeError as exc:
        raise FieldError(f"`header.stamp`: {exc}") from None
