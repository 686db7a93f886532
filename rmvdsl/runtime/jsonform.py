"""Frozen dataclasses to JSON and back, exactly: numbers as exact decimals (or
quotients as strings), union members tagged by their class's `TAG` (`"node"`), and
a layout that keeps small objects on one line. Standard library only; the resolved
spec (rmvdsl.runtime.spec) is written and read with it."""

from __future__ import annotations

import dataclasses
import functools
import json
import re
import types
import typing
from collections.abc import Callable, Mapping
from fractions import Fraction
from typing import Any

from rmvdsl.runtime.values import exact_text

# (class, field) -> (to JSON, from JSON): a field that travels in another form.
Conversions = dict[tuple[type, str], tuple[Callable[[Any], Any], Callable[[Any], Any]]]


class Codec:
    """`tagged`: TAG -> class, for the members of unions; `namespace`: where the
    classes' annotations are resolved; `conversions`: fields in another form."""

    def __init__(
        self, tagged: Mapping[str, type], namespace: dict[str, Any], conversions: Conversions
    ) -> None:
        self.tagged = tagged
        self.namespace = namespace
        self.conversions = conversions
        # Made once per annotation, per class: a spec holds thousands of each.
        self.decoders: dict[Any, Callable[[Any], Any]] = {}
        self.readers: dict[type, tuple[frozenset[str], tuple[_Field, ...]]] = {}
        self.writers: dict[type, tuple[dict[str, Any], tuple[_Field, ...]]] = {}

    def dump(self, value: Any, indent: int | None = 2) -> str:
        """The JSON text: exact numbers (a decimal where one is exact, else the
        quotient as a string such as "1/3"), fields in declaration order."""
        numbers: list[str] = []

        def number(value: Fraction) -> str:
            text = exact_text(value)
            if "/" in text:
                return text  # a quotient is written as a string
            numbers.append(text)
            return f"\x00{len(numbers) - 1}\x00"

        text = _pretty(self.encode(value, number), indent or 0, 0)
        return re.sub(r'"\\u0000(\d+)\\u0000"', lambda m: numbers[int(m.group(1))], text)

    def encode(self, value: Any, number: Any) -> Any:
        kind = type(value)
        if kind is str or kind is bool or value is None:
            return value
        if kind is Fraction:
            return number(value)
        if kind is int:
            return number(Fraction(value))
        if kind is tuple or kind is list:
            return [self.encode(item, number) for item in value]
        if kind not in self.writers and not dataclasses.is_dataclass(value):
            return self._encode_other(value, number)  # a subclass of the above
        head, fields = self.writer(kind)
        out = dict(head)
        for name, conversion, _ in fields:
            content = getattr(value, name)
            out[name] = self.encode(content if conversion is None else conversion[0](content),
                                    number)  # fmt: skip
        return out

    def _encode_other(self, value: Any, number: Any) -> Any:
        if isinstance(value, bool | str):
            return value
        if isinstance(value, int):
            return number(Fraction(value))
        if isinstance(value, Fraction):
            return number(value)
        if isinstance(value, tuple | list):
            return [self.encode(item, number) for item in value]
        raise TypeError(f"cannot encode {type(value).__name__}")

    def writer(self, cls: type) -> tuple[dict[str, Any], tuple[_Field, ...]]:
        """What a class's objects start as (their tag) and their fields, once."""
        found = self.writers.get(cls)
        if found is None:
            tag = getattr(cls, "TAG", None)
            fields = tuple((f.name, self.conversions.get((cls, f.name)), None)
                           for f in dataclasses.fields(cls))  # fmt: skip
            found = self.writers[cls] = ({"node": tag} if tag is not None else {}, fields)
        return found

    def decode(self, annotation: Any, value: Any) -> Any:
        return self.decoder(annotation)(value)

    def decoder(self, annotation: Any) -> Callable[[Any], Any]:
        """What reads a value of `annotation` from JSON, made once per annotation
        (the ones inside it are looked up when first read: a class may hold its
        own kind)."""
        found = self.decoders.get(annotation)
        if found is None:
            found = self.decoders[annotation] = self._made(annotation)
        return found

    def _made(self, annotation: Any) -> Callable[[Any], Any]:
        origin = typing.get_origin(annotation)
        if annotation is Any:
            return _as_is
        if origin in (typing.Union, types.UnionType):
            return self._union(annotation)
        if origin is tuple:
            arguments = typing.get_args(annotation)
            if len(arguments) == 2 and arguments[1] is Ellipsis:
                return functools.partial(self._many, arguments[0])
            return functools.partial(self._fixed, arguments)
        if annotation is Fraction:
            return _fraction
        if annotation is int:
            return _integer
        if annotation is bool or annotation is str:
            return functools.partial(_exactly, annotation)
        if dataclasses.is_dataclass(annotation):
            return functools.partial(self._decode_object, annotation)
        raise TypeError(f"cannot decode {annotation}")

    def _union(self, annotation: Any) -> Callable[[Any], Any]:
        arguments = typing.get_args(annotation)
        options = [a for a in arguments if a is not type(None)]
        optional = len(options) < len(arguments)

        def read(value: Any) -> Any:
            if value is None:
                if not optional:
                    raise ValueError("null where a value is needed")
                return None
            if len(options) == 1:
                return self.decoder(options[0])(value)
            return self._decode_tagged(options, value)

        return read

    def _many(self, item: Any, value: Any) -> tuple[Any, ...]:
        if not isinstance(value, list):
            raise ValueError(f"expected a list, not {str(value)[:40]}")
        read = self.decoder(item)
        return tuple([read(v) for v in value])

    def _fixed(self, arguments: tuple[Any, ...], value: Any) -> tuple[Any, ...]:
        if not isinstance(value, list):
            raise ValueError(f"expected a list, not {str(value)[:40]}")
        return tuple(self.decode(a, item) for a, item in zip(arguments, value, strict=True))

    def _decode_tagged(self, options: list[Any], value: Any) -> Any:
        if not isinstance(value, dict) or value.get("node") not in self.tagged:
            raise ValueError(f"expected a node, not {str(value)[:40]}")
        cls = self.tagged[value["node"]]
        if cls not in options:
            raise ValueError(f"a `{value['node']}` node cannot stand here")
        return self._decode_object(cls, value)

    def _decode_object(self, cls: Any, value: Any) -> Any:
        if not isinstance(value, dict):
            raise ValueError(f"expected an object for {cls.__name__}, not {str(value)[:40]}")
        known, fields = self.reader(cls)
        if not known.issuperset(value):
            extra = set(value) - known
            raise ValueError(f"unknown keys in {cls.__name__}: {', '.join(sorted(extra))}")
        arguments = {}
        for name, conversion, annotation in fields:
            if name not in value:
                raise ValueError(f"{cls.__name__} has no `{name}`")
            if conversion is not None:
                arguments[name] = conversion[1](value[name])
            else:
                arguments[name] = self.decoder(annotation)(value[name])
        return cls(**arguments)

    def reader(self, cls: type) -> tuple[frozenset[str], tuple[_Field, ...]]:
        """A class's keys (its fields and the tag) and its fields' annotations, once."""
        found = self.readers.get(cls)
        if found is None:
            hints = typing.get_type_hints(cls, self.namespace)
            names = [f.name for f in dataclasses.fields(cls)]
            fields = tuple((n, self.conversions.get((cls, n)), hints[n]) for n in names)
            found = self.readers[cls] = (frozenset([*names, "node"]), fields)
        return found


# A field: its name, its conversion (to JSON, from JSON) if it travels in another
# form, its annotation (a reader's).
_Field = tuple[str, "tuple[Callable[[Any], Any], Callable[[Any], Any]] | None", Any]


def _as_is(value: Any) -> Any:
    return value


def _fraction(value: Any) -> Fraction:
    if not isinstance(value, str):
        raise ValueError(f"expected a number, not {str(value)[:40]}")
    return Fraction(value)


def _integer(value: Any) -> int:
    if not isinstance(value, str) or not _INTEGER.fullmatch(value):
        raise ValueError(f"expected an integer, not {str(value)[:40]}")
    return int(value)


_INTEGER = re.compile(r"-?\d+")


def _exactly(kind: type, value: Any) -> Any:
    if not isinstance(value, kind):
        raise ValueError(f"expected a {kind.__name__}, not {str(value)[:40]}")
    return value


def _pretty(value: Any, indent: int, depth: int) -> str:
    """JSON with each object or list on one line when it fits in 100 columns (a
    formula, a type, a pattern), else one item per line. Below depth 12 all is on
    one line: a formula nesting 100,000 levels would otherwise be indented by
    gigabytes of spaces."""
    wide = isinstance(value, dict | list) and indent and depth < _MAX_INDENTED
    if not wide or _fits(value, 100 - indent * depth):
        return _ONE_LINE(value)
    pad, inner = " " * indent * depth, " " * indent * (depth + 1)
    if isinstance(value, dict):
        items = [
            f"{inner}{_ONE_LINE(k)}: {_pretty(v, indent, depth + 1)}" for k, v in value.items()
        ]
        return "{\n" + ",\n".join(items) + f"\n{pad}}}" if items else "{}"
    items = [inner + _pretty(v, indent, depth + 1) for v in value]
    return "[\n" + ",\n".join(items) + f"\n{pad}]" if items else "[]"


_MAX_INDENTED = 12
# One encoder for every call: json.dumps with arguments builds a new one each time.
_ONE_LINE = json.JSONEncoder(ensure_ascii=False, separators=(", ", ": ")).encode


def _fits(value: Any, budget: int) -> bool:
    """Whether the one-line JSON of `value` is at most `budget` characters; stops
    counting once it is longer, so the cost is bounded whatever the size."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            budget -= 2
            for key, content in item.items():
                budget -= len(key) + 6
                stack.append(content)
        elif isinstance(item, list):
            budget -= 2
            stack.extend(item)
        elif isinstance(item, str):
            budget -= len(item) + 4  # quotes and separator; escapes are rare in names
        else:
            budget -= 7  # true, false, null
        if budget < 0:
            return False
    return True
