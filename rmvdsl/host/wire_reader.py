"""The code generator of rmvdsl.host.partial_decoding: from rosbags' field
descriptions of a message type and the fields to read, Python source that reads
them from the serialized bytes and skips the rest by size.

A run of fixed-size fields is one static offset, each run of read fields one
`struct.Struct.unpack_from`, a string or a sequence is skipped by its length and
an array of fixed-size elements by count times stride; CDR alignment is tracked
statically and written out only where it cannot be known. The source names only
its own variables; a field's name reaches it only as a checked identifier, the
argument of a generated class's constructor.
"""

from __future__ import annotations

import keyword
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

BASE, NAME, ARRAY, SEQUENCE = 1, 2, 3, 4
# struct's format of each primitive, as rosbags unpacks it (`byte` signed, `char`
# unsigned, `bool` any nonzero byte).
FORMATS = {
    "bool": "?", "byte": "b", "char": "B", "int8": "b", "uint8": "B",
    "int16": "h", "uint16": "H", "int32": "i", "uint32": "I",
    "int64": "q", "uint64": "Q", "float32": "f", "float64": "d",
}  # fmt: skip
# ROS 2 gives an empty message one member, which ROS 1's wire format leaves out.
PLACEHOLDER = "structure_needs_at_least_one_member"

# What is read of a message: field name -> what is read of that field (None: all
# of it). An array's entry says what is read of each of its elements.
Needs = dict[str, "Needs | None"]
FieldsOf = Callable[[str], Sequence[tuple[str, Any]]]
Reader = Callable[[bytes | memoryview], Any]


def _size(base: str) -> int:
    """The bytes of a primitive (any this reader knows)."""
    fmt = FORMATS.get(base)
    if fmt is None:
        raise Unsupported(f"the primitive type {base}")
    return struct.calcsize(fmt)


class PartialDecodeError(ValueError):
    """The bytes do not fit the definition where this reader looked."""


class Unreadable(PartialDecodeError):
    """Bytes the full decoder must not be given either: a count of elements of no
    bytes (empty messages in ROS 1) past MOST_EMPTY, which rosbags' decoder would
    make one by one, without bound (a damaged count of 2^31 took all memory)."""


# Elements of no bytes a ROS 1 sequence may count before it is refused as
# unreadable (rosbags makes each: a million is about 50 MB).
MOST_EMPTY = 1 << 20


class Unsupported(Exception):
    """A definition this reader does not compile; the full decoder reads it."""


def compiled(type_name: str, needs: Needs, fields_of: FieldsOf, *, ros1: bool) -> Reader:
    """A reader of `type_name`'s messages (ROS 1, or CDR of either byte order)
    that decodes `needs`; raises Unsupported for a definition it cannot read."""
    try:
        if ros1:
            return _Compiler(fields_of, ros1=True, order="<").top(type_name, needs)
        # the encapsulation header: 00 01 little-endian CDR, 00 00 big-endian; each
        # reader checks its own and hands any other on (a call fewer a message)
        big = _Compiler(fields_of, ros1=False, order=">").top(type_name, needs, (0, _not_cdr))
        return _Compiler(fields_of, ros1=False, order="<").top(type_name, needs, (1, big))
    except RecursionError as error:  # a definition that contains itself
        raise Unsupported("definitions nested too deep") from error


def fewest_bytes(description: Any, fields_of: FieldsOf, *, ros1: bool) -> int:
    """The fewest bytes a field of `description` (kind, detail) takes; raises
    Unsupported for a definition this reader does not compile."""
    try:
        return _Compiler(fields_of, ros1=ros1, order="<")._least(description)
    except RecursionError as error:  # a definition that contains itself
        raise Unsupported("definitions nested too deep") from error


def _not_cdr(raw: bytes | memoryview) -> Any:
    raise PartialDecodeError("not CDR: unknown encapsulation")


@dataclass
class _Segment:
    """Fields read at static offsets from one runtime position, unpacked at once."""

    # offset, format, element count (None: one value, not an array), variable
    reads: list[tuple[int, str, int | None, str]] = field(default_factory=list)


@dataclass
class _Body:
    """One generated function's state while its lines are written: the position is
    `p + offset` with `p` a runtime value known to be `known`-aligned."""

    lines: list[str] = field(default_factory=list)
    offset: int = 0
    known: int = 8
    segment: _Segment = field(default_factory=_Segment)
    objects: list[str] = field(default_factory=list)  # constructions, inner first
    counter: int = 0

    def name(self, prefix: str) -> str:
        self.counter += 1
        return f"{prefix}{self.counter}"


class _Compiler:
    def __init__(self, fields_of: FieldsOf, *, ros1: bool, order: str) -> None:
        self.fields_of = fields_of
        self.ros1 = ros1
        self.order = order
        self.names: dict[str, Any] = {
            "_unpack_from": struct.unpack_from,
            "_Error": PartialDecodeError,
            "_Unreadable": Unreadable,
            "_Errors": (struct.error, UnicodeDecodeError, IndexError, ValueError),
            "_LENGTH": "the message is longer or shorter than its definition",
        }
        self.functions: dict[tuple[str, str], str] = {}
        self.source: list[str] = []
        self.sizes: dict[str, tuple[int, int]] = {}  # type -> (fixed size | -1, alignment)

    # ---- the whole reader ----

    def top(self, type_name: str, needs: Needs, header: tuple[int, Reader] | None = None) -> Reader:
        """The reader; a CDR one (`header`) reads the byte order its encapsulation
        header's second byte names, and hands a message of another to the reader
        given with it."""
        body = _Body(known=8)
        if header is not None:
            order, self.names["_other"] = header
            body.lines.append(
                f"if len(raw) < 4 or raw[0] != 0 or raw[1] != {order}: return _other(raw)"
            )
        start = 0 if self.ros1 else 4  # CDR positions count from the header's end
        body.lines.append(f"p = {start}")
        value = self._message(body, type_name, needs, read=True)
        self._flush(body)
        end = self._position(body)
        body.lines.extend(body.objects)
        if self.ros1:
            body.lines.append(f"if {end} != len(raw): raise _Error(_LENGTH)")
        else:  # rosbags allows up to 3 bytes of padding after the last field
            body.lines.append(f"end = {end}")
            body.lines.append("if end > len(raw) or end + 3 < len(raw): raise _Error(_LENGTH)")
        body.lines.append(f"return {value}")
        # A message that does not fit the definition fails in many ways: each is
        # said as a PartialDecodeError, caught in the reader itself.
        body.lines = [
            "try:", *(f"    {line}" for line in body.lines),
            "except _Unreadable:", "    raise",
            "except _Errors as error:", "    raise _Error(str(error)) from None",
        ]  # fmt: skip
        self._define("read", "raw", body)
        namespace = dict(self.names)
        exec("\n".join(self.source), namespace)  # generated here: no name from a definition
        reader: Reader = namespace["read"]
        return reader

    def _define(self, name: str, parameters: str, body: _Body) -> None:
        self.source.append(f"def {name}({parameters}):")
        self.source.extend(f"    {line}" for line in body.lines)

    # ---- fields ----

    def _fields(self, type_name: str) -> list[tuple[str, Any]]:
        try:
            fields = list(self.fields_of(type_name))
        except KeyError as error:
            raise Unsupported(f"no definition of {type_name}") from error
        if self.ros1:
            fields = [(n, d) for n, d in fields if n != PLACEHOLDER]
        return fields

    def _message(self, body: _Body, type_name: str, needs: Needs | None, read: bool) -> str | None:
        """Walk a nested message's fields (reading `needs`, all when None); the
        variable of its object when it is read."""
        fields = self._fields(type_name)
        if needs:
            missing = sorted(set(needs) - {name for name, _ in fields})
            if missing:
                raise Unsupported(f"{type_name} has no field {missing[0]}")
        values: list[tuple[str, str]] = []
        for name, (kind, detail) in fields:
            wanted = read and (needs is None or name in needs)
            inner = None if needs is None else needs.get(name)
            value = self._field(body, int(kind), detail, wanted, inner)
            if wanted:
                assert value is not None
                values.append((name, value))
        if not read:
            return None
        cls = self._class(type_name, [n for n, _ in values])
        variable = body.name("o")
        body.objects.append(f"{variable} = {cls}({', '.join(v for _, v in values)})")
        return variable

    def _field(
        self, body: _Body, kind: int, detail: Any, read: bool, needs: Needs | None
    ) -> str | None:
        if kind == BASE:
            base, _bound = detail
            if base == "string":
                return self._string(body, read)
            return self._primitive(body, base, read)
        if kind == NAME:
            return self._message(body, detail, needs, read)
        element, count = detail
        if kind == ARRAY:
            return self._elements(body, element, str(count), read, needs, fixed=count)
        if kind == SEQUENCE:
            self._align(body, 4)
            length = body.name("n")
            self._add(body, "I", None, length)
            self._flush(body)
            body.offset += 4
            return self._elements(body, element, length, read, needs, fixed=None)
        raise Unsupported(f"a field of kind {kind}")

    def _primitive(self, body: _Body, base: str, read: bool) -> str | None:
        fmt = FORMATS.get(base)
        if fmt is None:
            raise Unsupported(f"the primitive type {base}")
        size = struct.calcsize(fmt)
        self._align(body, size)
        variable = None
        if read:
            variable = body.name("v")
            self._add(body, fmt, None, variable)
        body.offset += size
        return variable

    def _string(self, body: _Body, read: bool) -> str | None:
        self._align(body, 4)
        length = body.name("n")
        self._add(body, "I", None, length)
        self._flush(body)
        here = self._position(body)
        variable = None
        terminator = 0 if self.ros1 else 1
        if not self.ros1:  # read or not: a CDR string ends in NUL (rosbags checks it)
            body.lines.append(f"if {length} < 1 or raw[{here} + 3 + {length}] != 0: "
                              "raise _Error('a string without its terminator')")  # fmt: skip
        if read:
            variable = body.name("s")
            body.lines.append(
                f"{variable} = bytes(raw[{here} + 4:{here} + 4 + {length} - {terminator}]).decode()"
            )
        body.lines.append(f"p = {here} + 4 + {length}")
        body.offset, body.known = 0, 1
        return variable

    def _elements(
        self, body: _Body, element: Any, count: str, read: bool, needs: Needs | None,
        fixed: int | None,
    ) -> str | None:  # fmt: skip
        """The elements of an array (`fixed` of them) or a sequence (`count`, a
        variable): skipped by their size when every element has the same, else
        walked one by one."""
        kind, detail = int(element[0]), element[1]
        if kind == BASE and detail[0] != "string":
            return self._primitives(body, detail[0], count, read, fixed)
        if kind == NAME and fixed == 0 and not self.ros1:
            # rosbags takes what follows as aligned to the element's last field,
            # which holds only when there are elements: it lays out the next
            # field unlike CDR, and its full decoder is the one that reads alike
            raise Unsupported("an array of no messages in CDR")
        if not read and kind == NAME:
            stride, alignment = self._stride(detail)
            if stride >= 0:
                self._align_if(body, alignment, count, fixed)
                if fixed is not None:
                    body.offset += fixed * stride
                    return None
                self._flush(body)
                body.lines.append(f"p = {self._position(body)}")
                self._check_count(body, element, count)
                body.lines.append(f"p += {count} * {stride}")
                body.offset, body.known = 0, min(4, alignment)
                return None
        function = self._function(kind, detail, needs, read)
        if fixed is not None:
            self._align(body, self._first(element))
        self._flush(body)
        if body.offset:
            body.lines.append(f"p = {self._position(body)}")
        if fixed is None:  # a damaged count must not make the loop run for ever
            self._check_count(body, element, count)
        variable = body.name("a") if read else None
        if read:
            body.lines.append(f"{variable} = []")
            body.lines.append(f"for _ in range({count}):")
            body.lines.append(f"    e, p = {function}(raw, p)")
            body.lines.append(f"    {variable}.append(e)")
        else:
            body.lines.append(f"for _ in range({count}):")
            body.lines.append(f"    p = {function}(raw, p)[1]")
        body.offset, body.known = 0, 1
        return variable

    def _primitives(
        self, body: _Body, base: str, count: str, read: bool, fixed: int | None
    ) -> str | None:
        fmt = FORMATS.get(base)
        if fmt is None:
            raise Unsupported(f"the primitive type {base}")
        size = struct.calcsize(fmt)
        self._align_if(body, size, count, fixed)
        variable = body.name("t") if read else None
        if fixed is not None:
            if variable is not None and fixed:
                self._add(body, fmt, fixed, variable)
            elif variable is not None:
                body.lines.append(f"{variable} = ()")
            body.offset += fixed * size
            return variable
        self._flush(body)
        here = self._position(body)
        if variable is not None:
            body.lines.append(f"{variable} = _unpack_from('{self.order}%d{fmt}' % {count}, "
                              f"raw, {here})")  # fmt: skip
        body.lines.append(f"p = {here} + {count} * {size}")
        body.offset, body.known = 0, min(4, size)
        return variable

    def _function(self, kind: int, detail: Any, needs: Needs | None, read: bool) -> str:
        """A function that reads one element at `p`: returns (value, end)."""
        key = (repr((kind, detail)), repr((needs, read)))
        name = self.functions.get(key)
        if name is not None:
            return name
        name = self.functions[key] = f"element{len(self.functions)}"
        body = _Body(known=1)
        if kind == NAME:
            value = self._message(body, detail, needs, read)
        else:
            value = self._string(body, read)
        self._flush(body)
        end = self._position(body)
        body.lines.extend(body.objects)
        body.lines.append(f"return {value}, {end}")
        self._define(name, "raw, p", body)
        return name

    # ---- sizes and alignment ----

    def _check_count(self, body: _Body, element: Any, count: str) -> None:
        """Refuse a sequence's count (at `p`) longer than the message can hold, as
        rosbags' full decoder does, whether its elements are walked or skipped."""
        least = self._least(element)
        if self.ros1 and least == 0:
            too_many = (
                f"'a sequence longer than the message: a count of ' + str({count})"
                " + ' messages of no bytes'"
            )
            body.lines.append(f"if {count} > {MOST_EMPTY}: raise _Unreadable({too_many})")
        body.lines.append(f"if {self._too_many(least, count)}: "
                          "raise _Error('a sequence longer than the message')")  # fmt: skip

    def _too_many(self, least: int, count: str) -> str:
        """The test that a sequence's count, of elements of at `least` bytes, is
        more than its message can hold. Elements of no bytes (empty messages in
        ROS 1, messages of arrays of length 0) fit any number of times: in ROS 1
        their count is bounded by the message's length only, so a damaged count
        still cannot make the loop run for ever. In CDR rosbags' full decoder takes
        each message element for a byte at least (a ROS 2 message has a field), and
        refuses a longer count: so does this."""
        if least == 0 and self.ros1:
            return f"{count} > len(raw)"
        least = max(least, 1)
        return f"{count}{f' * {least}' if least > 1 else ''} > len(raw) - p"

    def _least(self, description: Any) -> int:
        """The fewest bytes a value takes (a sequence's count is checked against
        the bytes left before its elements are walked)."""
        kind, detail = int(description[0]), description[1]
        if kind == BASE:
            if detail[0] == "string":
                return 4 if self.ros1 else 5
            return _size(detail[0])
        if kind == ARRAY:
            return detail[1] * self._least(detail[0])
        if kind == SEQUENCE:
            return 4
        return sum(self._least(d) for _, d in self._fields(detail))

    def _stride(self, type_name: str) -> tuple[int, int]:
        """The bytes each element of an array of `type_name` takes when all take
        the same, and the alignment they start at; (-1, 0) when they do not. In
        CDR that needs a fixed size, a multiple of the largest alignment inside,
        which is also the first field's."""
        cached = self.sizes.get(type_name)
        if cached is not None:
            return cached
        body = _Body(known=8)
        self._message(body, type_name, {}, read=False)
        largest = self._largest((NAME, type_name))
        first = self._first((NAME, type_name))
        fixed = not body.lines and not body.segment.reads
        even = self.ros1 or (body.offset % largest == 0 and first == largest)
        result = (body.offset, largest) if fixed and even else (-1, 0)
        self.sizes[type_name] = result
        return result

    def _largest(self, description: Any) -> int:
        kind, detail = int(description[0]), description[1]
        if kind == BASE:
            return 4 if detail[0] == "string" else _size(detail[0])
        if kind == NAME:
            return max((self._largest(d) for _, d in self._fields(detail)), default=1)
        return max(4 if kind == SEQUENCE else 1, self._largest(detail[0]))

    def _first(self, description: Any) -> int:
        kind, detail = int(description[0]), description[1]
        if kind == BASE:
            return 4 if detail[0] == "string" else _size(detail[0])
        if kind == NAME:
            fields = self._fields(detail)
            return self._first(fields[0][1]) if fields else 1
        return 4 if kind == SEQUENCE else self._first(detail[0])

    def _align(self, body: _Body, size: int) -> None:
        if self.ros1 or size <= 1:
            return
        if size <= body.known:
            body.offset = -(-body.offset // size) * size
            return
        self._flush(body)
        here = self._position(body)
        body.lines.append(f"p = (({here} - 4 + {size - 1}) & {-size}) + 4")
        body.offset, body.known = 0, size

    def _align_if(self, body: _Body, size: int, count: str, fixed: int | None) -> None:
        """A sequence's elements are aligned only when there are any (rosbags'
        rule, as the CDR it writes)."""
        if self.ros1 or size <= 1:
            return
        if fixed is not None:  # a fixed-size array is aligned even when empty
            self._align(body, size)
            return
        if size <= body.known and body.offset % size == 0:
            return
        self._flush(body)
        here = self._position(body)
        body.lines.append(f"p = (({here} - 4 + {size - 1}) & {-size}) + 4 if {count} else {here}")
        # just after a count: 4-aligned with no element, `size`-aligned with some
        body.offset, body.known = 0, min(4, size)

    @staticmethod
    def _position(body: _Body) -> str:
        return f"p + {body.offset}" if body.offset else "p"

    # ---- reads at static offsets ----

    def _add(self, body: _Body, fmt: str, count: int | None, variable: str) -> None:
        body.segment.reads.append((body.offset, fmt, count, variable))

    def _flush(self, body: _Body) -> None:
        reads = body.segment.reads
        if not reads:
            return
        body.segment = _Segment()
        start = reads[0][0]
        parts, at = [self.order], start
        for offset, fmt, count, _ in reads:
            if offset > at:
                parts.append(f"{offset - at}x")
            parts.append(f"{count or ''}{fmt}")
            at = offset + (count or 1) * struct.calcsize(fmt)
        unpacker = f"_S{len(self.names)}"
        self.names[unpacker] = struct.Struct("".join(parts))
        where = f"p + {start}" if start else "p"
        if all(count is None for _, _, count, _ in reads):
            targets = ", ".join(variable for *_, variable in reads)
            body.lines.append(f"{targets}, = {unpacker}.unpack_from(raw, {where})")
            return
        body.lines.append(f"u = {unpacker}.unpack_from(raw, {where})")
        index = 0
        for _, _, count, variable in reads:
            if count is None:
                body.lines.append(f"{variable} = u[{index}]")
                index += 1
            else:
                body.lines.append(f"{variable} = u[{index}:{index + count}]")
                index += count

    # ---- the objects returned ----

    def _class(self, type_name: str, names: list[str]) -> str:
        for name in names:  # ROS names a field [a-zA-Z][a-zA-Z0-9_]*: other text is left out
            if not name.isidentifier() or keyword.iskeyword(name) or name.startswith("_"):
                raise Unsupported(f"the field name {name!r}")
        if len(set(names)) != len(names):
            raise Unsupported(f"two fields of {type_name} have one name")
        key = f"_C{len(self.names)}"
        self.names[key] = _message_class(type_name, tuple(names))
        return key


def _message_class(type_name: str, names: tuple[str, ...]) -> type:
    """A class of the fields read of `type_name`, made once per set of names."""
    made = _CLASSES.get((type_name, names))
    if made is not None:
        return made
    source = "\n".join([
        f"def __init__(_self, {', '.join(names)}):",  # no field is named `_self`
        *(f"    _self.{name} = {name}" for name in names),
        "    pass",  # a message of no fields read (an empty one, read whole)
    ])  # fmt: skip
    namespace: dict[str, Any] = {}
    exec(source, namespace)  # the names: identifiers, checked
    cls = type(type_name.rsplit("/", 1)[-1], (), {
        "__slots__": names, "__init__": namespace["__init__"],
        "__repr__": _repr, "__msgtype__": type_name,
    })  # fmt: skip
    if len(_CLASSES) >= KEPT_CLASSES:
        _CLASSES.clear()  # made again when needed: memory stays flat
    _CLASSES[(type_name, names)] = cls
    return cls


def _repr(self: Any) -> str:
    inner = ", ".join(f"{name}={getattr(self, name)!r}" for name in self.__slots__)
    return f"{type(self).__name__}({inner})"


KEPT_CLASSES = 256  # classes kept: memory stays flat over any fleet of definitions
_CLASSES: dict[tuple[str, tuple[str, ...]], type] = {}
