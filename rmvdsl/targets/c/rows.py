"""A row of a query (a topic's values at one time) as C: the compiler of the
expressions a query reads from its rows, with the streaming transformations'
state, and what compiling used (docs/c.md, "Queries")."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.functions import STREAMS
from rmvdsl.runtime.influx import _second
from rmvdsl.runtime.series import NS
from rmvdsl.targets.c.cexpr import Compiler, Value, c_int
from rmvdsl.targets.c.model import Unsupported

MEMBER = {"bool": "b", "int": "i", "float": "f"}  # a kind's member of rmv_value
# The streaming transformations, as rmv_push's codes.
STREAM_CODES = {"derivative": "d", "non_negative_derivative": "D", "difference": "f",
                "non_negative_difference": "F", "cumulative_sum": "c", "elapsed": "e"}  # fmt: skip


@dataclass
class Compiled:
    """What compiling a query used, for the template and the monitor's size."""

    helpers: set[str] = field(default_factory=set)
    floats: bool = False
    libm: bool = False

    def take(self, compiler: Compiler) -> None:
        self.helpers |= compiler.helpers
        self.floats |= compiler.floats
        self.libm |= compiler.libm


@dataclass
class RowCompiler(Compiler):
    """An expression over a query's row `r`: the streaming transformations (in a
    raw query) push the row's value into their state, `m->stream[k]` from
    `stream_first` on, where it has one."""

    stream_first: int = 0
    streams: int = 0  # states so far

    def call(self, node: ir.Call) -> Value:
        if node.function not in STREAMS:
            return super().call(node)
        code = STREAM_CODES.get(node.function)
        if code is None:
            raise Unsupported(f"`{node.function}` (not computed in C)")
        inner = self.expr(node.args[0])
        if inner.kind not in ("int", "float"):
            raise Unsupported(f"`{node.function}` of a {inner.kind}")
        out = stream_kind(node.function, inner.kind)
        if "float" in (inner.kind, out):
            self.floats = True
        state = self.stream_first + self.streams
        self.streams += 1
        self.helpers |= {"push", "add", "sub", "i64"}
        name = f"q{self.count}"
        value = f"(rmv_value){{.{MEMBER[inner.kind]} = {inner.value}}}"
        unit = c_int(unit_of(node))
        self.lines.append(
            f"const rmv_maybe {name} = {inner.present} ? rmv_push(&m->stream[{state}], "
            f"'{code}', '{inner.kind[0]}', r->t, {value}, {unit}) : rmv_none();"
        )
        return self.temporary(out, f"{name}.has", f"{name}.v.{MEMBER[out]}")


def stream_kind(function: str, kind: str) -> str:
    """The kind a streaming transformation gives of a `kind`."""
    if function in ("derivative", "non_negative_derivative"):
        return "float"
    if function == "elapsed":
        return "int"
    return kind


def unit_of(call: ir.Call) -> int:
    """A transformation's unit in ns (derivative's 1s, elapsed's 1ns by default)."""
    second = _second(call)
    return int(second) if second is not None else NS


def row_compiler(sources: Mapping[str, tuple[int, str]], stream_first: int = 0) -> RowCompiler:
    return RowCompiler(
        sources, {}, has_at="r->has[{}]", value_at="r->val[{}]", stream_first=stream_first
    )
