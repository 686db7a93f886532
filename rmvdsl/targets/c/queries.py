"""The spec's value events (InfluxQL queries) as C: what rmvdsl.runtime.influx
computes, in templates/queries.c.inc (docs/c.md, "Queries").

A raw query (no window) is a function of one row: a topic's message at one time,
with its streaming transformations' state in the monitor. A windowed query is a
continuous query: the engine schedules its runs as InfluxDB's continuous querier
does, and each run is a generated function over the rows of its range that
computes every subexpression as a series over the run's windows (slots), as
WindowedQuery.execute does with dicts: aggregates and `fill`, transformations of
series, then the operators slot by slot.

A query C does not compute raises Unsupported with the reason: its points stay an
input the host gives."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.expressions import number_value
from rmvdsl.runtime.functions import ELEMENTWISE, STREAMS
from rmvdsl.runtime.influx import LOOKBACK, _second
from rmvdsl.runtime.series import NS, nanoseconds
from rmvdsl.targets.c.cexpr import Compiler, Value, c_double, c_int
from rmvdsl.targets.c.model import Unsupported

# The aggregations and selectors C computes, and the kind of what each gives.
AGGREGATES = {"count": "int", "sum": "", "mean": "float", "min": "", "max": "", "first": "",
              "last": "", "spread": "", "stddev": "float"}  # fmt: skip
# The streaming transformations, as rmv_push's codes.
_STREAM_CODES = {"derivative": "d", "non_negative_derivative": "D", "difference": "f",
                 "non_negative_difference": "F", "cumulative_sum": "c", "elapsed": "e"}  # fmt: skip
_MEMBER = {"bool": "b", "int": "i", "float": "f"}


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


@dataclass(frozen=True)
class Query:
    """One value event the monitor computes (templates/queries.c.inc)."""

    name: str
    value: int  # its index among the monitor's values
    kind: str  # bool | int | float
    reads: tuple[int, ...]  # the values it reads: a row holds at least one
    windowed: bool
    lines: tuple[str, ...]  # raw: statements over row `r`; windowed: the run's body
    present: str = ""  # raw: a C expression, 1 where the row gives a point
    result: str = ""  # raw: the point's value
    streams: int = 0  # raw: stream states it keeps (in the monitor's pool)
    stream_first: int = 0
    interval: int = 0  # windowed: ns
    offset: int = 0
    every: int = 0
    span: int = 0
    lookback: int = 0
    slots: int = 1  # windows a run computes at most, lookback included
    series: int = 1  # series a run computes
    depth: int = 0  # how many windows before a run's range its deepest read reaches
    rows: int = 1  # rows it holds at most (from its topics' max_rate)
    row_first: int = 0  # where its rows start in the monitor's pool
    written: int = 1  # points written and not yet final, at most
    written_first: int = 0
    reads_first: int = 0  # where its reads start in QUERY_READS
    used: Compiled | None = None  # the helpers, doubles and libm it needs

    @property
    def member(self) -> str:
        return _MEMBER[self.kind]

    @property
    def lag(self) -> int:
        """How far the time its points are final lags the input's (ns):
        rmvdsl.runtime.influx.EventState.final_before is at most a run's span and
        a window behind."""
        return self.span + self.interval


class RowCompiler(Compiler):
    """A raw query's expression over a row: the streaming transformations push
    the row's value into their state (`m->stream[k]`) where it has one."""

    stream_first: int = 0
    streams: int = 0

    def call(self, node: ir.Call) -> Value:
        if node.function not in STREAMS:
            return super().call(node)
        code = _STREAM_CODES.get(node.function)
        if code is None:
            raise Unsupported(f"`{node.function}` (not computed in C)")
        inner = self.expr(node.args[0])
        if inner.kind not in ("int", "float"):
            raise Unsupported(f"`{node.function}` of a {inner.kind}")
        out = _stream_kind(node.function, inner.kind)
        if "float" in (inner.kind, out):
            self.floats = True
        state = self.stream_first + self.streams
        self.streams += 1
        self.helpers |= {"push", "add", "sub", "i64"}
        name = f"q{self.count}"
        value = f"({self.value_type}){{.{_MEMBER[inner.kind]} = {inner.value}}}"
        unit = c_int(_unit(node))
        self.lines.append(
            f"const {self.maybe_type} {name} = {inner.present} ? rmv_push(&m->stream[{state}], "
            f"'{code}', '{inner.kind[0]}', r->t, {value}, {unit}) : {self.none};"
        )
        return self.temporary(out, f"{name}.has", f"{name}.v.{_MEMBER[out]}")

    value_type: str = ""
    maybe_type: str = ""
    none: str = ""


def _stream_kind(function: str, kind: str) -> str:
    if function in ("derivative", "non_negative_derivative"):
        return "float"
    if function == "elapsed":
        return "int"
    return kind


def _unit(call: ir.Call) -> int:
    second = _second(call)
    return int(second) if second is not None else NS


def row_compiler(sources: Mapping[str, tuple[int, str]], stream_first: int = 0) -> RowCompiler:
    compiler = RowCompiler(sources, {}, has_at="r->has[{}]", value_at="r->val[{}]")
    compiler.stream_first = stream_first
    compiler.value_type = "rmv_value"
    compiler.maybe_type = "rmv_maybe"
    compiler.none = "rmv_none()"
    return compiler


def compile_query(
    event: ir.Event, value: int, sources: Mapping[str, tuple[int, str]], stream_first: int
) -> Query:
    """The value event `event` (the monitor's value `value`) as C, reading the
    variables `sources`; raises Unsupported with why C does not compute it."""
    used = Compiled()
    if event.window is None:
        query = raw_query(event, value, sources, stream_first, used)
    else:
        query = windowed_query(event, value, sources, used)
    return replace(query, used=used)


def raw_query(
    event: ir.Event,
    value: int,
    sources: Mapping[str, tuple[int, str]],
    stream_first: int,
    used: Compiled,
) -> Query:
    """A value event with no window: one point per row, where every value it
    reads is in the row and `where` holds (RawQuery.row)."""
    lines: list[str] = []
    if event.where is not None:
        where = row_compiler(sources)
        holds = where.expr(event.where)
        test = f"{holds.present} && {holds.value}"
        lines += ["{", *(f"    {s}" for s in where.statements(test))]
        lines += [f"    if (!({test})) return 0;", "}"]
        used.take(where)
    compiler = row_compiler(sources, stream_first)
    result = compiler.expr(event.expr)
    used.take(compiler)
    return Query(
        name=event.name,
        value=value,
        kind=result.kind,
        reads=_reads(event, sources),
        windowed=False,
        lines=(*lines, *compiler.statements(f"{result.present} {result.value}")),
        present=result.present,
        result=result.value,
        streams=compiler.streams,
        stream_first=stream_first,
    )


def _reads(event: ir.Event, sources: Mapping[str, tuple[int, str]]) -> tuple[int, ...]:
    missing = [name for name in event.reads if name not in sources]
    if missing:
        raise Unsupported(f"it reads `{missing[0]}`, not a variable")
    return tuple(sources[name][0] for name in event.reads)


def windowed_query(
    event: ir.Event,
    value: int,
    sources: Mapping[str, tuple[int, str]],
    used: Compiled,
) -> Query:
    """A continuous query (WindowedQuery): its schedule, and the body of the
    function that computes one run's points."""
    window = event.window
    assert window is not None
    if event.tags:
        raise Unsupported("it groups by tags")
    interval = nanoseconds(window.interval)
    offset = nanoseconds(window.offset) % interval
    every, span = ir.resampling(window.interval, event.resample_every, event.resample_for)
    depth = _lookback_depth(event.expr)
    query = Query(
        name=event.name,
        value=value,
        kind="bool",
        reads=_reads(event, sources),
        windowed=True,
        lines=(),
        interval=interval,
        offset=offset,
        every=nanoseconds(every),
        span=nanoseconds(span),
        lookback=interval if depth else 0,
    )
    # A run's range holds at most (span + interval) / interval windows.
    slots = -(-(query.span + interval) // interval) + 1 + depth
    run = _Run(event, sources, depth, used)
    top = run.series(event.expr, 0)
    if not run.aggregated:
        raise Unsupported("no aggregation in a windowed query")
    run.points(top)
    return replace(
        query,
        kind=top.kind,
        lines=tuple(run.lines),
        slots=slots,
        series=max(1, run.count),
        depth=depth,
        written=2 * slots,
    )


def _lookback_depth(expr: ir.Expr) -> int:
    """How many windows before a run's range its deepest read reaches."""
    match expr:
        case ir.Call():
            inner = max((_lookback_depth(a) for a in expr.args), default=0)
            return inner + (1 if expr.function in LOOKBACK else 0)
        case ir.Binary():
            return max(_lookback_depth(expr.left), _lookback_depth(expr.right))
        case ir.Unary():
            return _lookback_depth(expr.operand)
    return 0


@dataclass(frozen=True)
class Series:
    index: int  # sp[index][slot], sv[index][slot]
    kind: str


@dataclass
class _Run:
    """The body of one windowed query's run function: series over the slots
    [lo, n) of each depth (depth d starts d windows before the run's range)."""

    event: ir.Event
    sources: Mapping[str, tuple[int, str]]
    depth: int  # the deepest lookback
    used: Compiled
    lines: list[str] = field(default_factory=list)
    count: int = 0  # series so far
    aggregated: bool = False

    def new(self, kind: str) -> Series:
        self.count += 1
        return Series(self.count - 1, kind)

    def lo(self, depth: int) -> int:
        return self.depth - depth

    def series(self, expr: ir.Expr, depth: int) -> Series:
        if isinstance(expr, ir.Call) and expr.function in AGGREGATES:
            return self.aggregate(expr, depth)
        if isinstance(expr, ir.Call) and expr.function in STREAMS:
            return self.stream(expr, depth)
        if isinstance(expr, ir.Call) and expr.function not in ELEMENTWISE:
            raise Unsupported(f"`{expr.function}` (not computed in C)")
        return self.slotwise(expr, depth)

    def slotwise(self, expr: ir.Expr, depth: int) -> Series:
        """Operators and transformations of one value, slot by slot, over the series
        of the aggregates and streams below (a window present on any of them is a
        key, as InfluxQL's join makes it; the value there may be none)."""
        leaves: dict[str, tuple[int, str]] = {}

        def cut(node: ir.Expr) -> ir.Expr:
            if isinstance(node, ir.Call) and node.function not in ELEMENTWISE:
                found = self.series(node, depth)
                name = f"\x00{found.index}"
                leaves[name] = (found.index, found.kind)
                return ir.Ref(name, "event", node.type)
            if isinstance(node, ir.Ref):
                raise Unsupported(f"`{node.name}` outside an aggregation")
            if isinstance(node, ir.Call):
                return replace(node, args=tuple(cut(a) for a in node.args))
            if isinstance(node, ir.Binary):
                return replace(node, left=cut(node.left), right=cut(node.right))
            if isinstance(node, ir.Unary):
                return replace(node, operand=cut(node.operand))
            return node

        rewritten = cut(expr)
        compiler = Compiler(leaves, {}, has_at="sp[{}][s]", value_at="sv[{}][s]")
        value = compiler.expr(rewritten)
        self.used.take(compiler)
        out = self.new(value.kind)
        keys = " || ".join(f"sp[{index}][s]" for index, _ in leaves.values()) or "0"
        present = f"({value.present}) && ({keys})"
        self.lines += [
            f"/* {out.index}: operators slot by slot */",
            f"for (s = 0; s < n; s++) sp[{out.index}][s] = 0;",
            f"for (s = {self.lo(depth)}; s < n; s++) {{",
            *(f"    {line}" for line in compiler.statements(present)),
            f"    sp[{out.index}][s] = (uint8_t)({present});",
            f"    if (sp[{out.index}][s])",
            f"        sv[{out.index}][s].{_MEMBER[value.kind]} = {value.value};",
            "}",
        ]
        return out

    def stream(self, call: ir.Call, depth: int) -> Series:
        code = _STREAM_CODES.get(call.function)
        if code is None:
            raise Unsupported(f"`{call.function}` (not computed in C)")
        inner_depth = depth + (1 if call.function in LOOKBACK else 0)
        inner = self.series(call.args[0], inner_depth)
        if inner.kind not in ("int", "float"):
            raise Unsupported(f"`{call.function}` of a {inner.kind}")
        kind = _stream_kind(call.function, inner.kind)
        if "float" in (kind, inner.kind):
            self.used.floats = True
        self.used.helpers |= {"push", "add", "sub", "i64"}
        out = self.new(kind)
        self.lines += [
            f"/* {out.index}: {call.function} */",
            "{",
            "    rmv_stream st;",
            "    memset(&st, 0, sizeof st);",
            f"    for (s = 0; s < n; s++) sp[{out.index}][s] = 0;",
            f"    for (s = {self.lo(inner_depth)}; s < n; s++) {{",
            "        rmv_maybe o;",
            f"        if (!sp[{inner.index}][s]) continue;",
            f"        o = rmv_push(&st, '{code}', '{inner.kind[0]}', base + s * I, "
            f"sv[{inner.index}][s], {c_int(_unit(call))});",
            f"        if (o.has && s >= {self.lo(depth)}) {{",
            f"            sp[{out.index}][s] = 1;",
            f"            sv[{out.index}][s] = o.v;",
            "        }",
            "    }",
            "}",
        ]
        return out

    def aggregate(self, call: ir.Call, depth: int) -> Series:
        """AGGREGATES over the rows of each window (reduce), then `fill` (_fill)."""
        self.aggregated = True
        function = call.function
        body: list[str] = []
        if self.event.where is not None:
            where = row_compiler(self.sources)
            holds = where.expr(self.event.where)
            self.used.take(where)
            test = f"{holds.present} && {holds.value}"
            body += ["{", *(f"    {s}" for s in where.statements(test)),
                     f"    if (!({test})) continue;", "}"]  # fmt: skip
        argument = row_compiler(self.sources)
        arg = argument.expr(call.args[0])
        self.used.take(argument)
        if arg.kind not in ("int", "float") and function != "count":
            raise Unsupported(f"`{function}` of a {arg.kind}")
        kind = AGGREGATES[function] or arg.kind
        if "float" in (kind, arg.kind):
            self.used.floats = True
        out = self.new(kind)
        nan = f" || !isfinite({arg.value})" if arg.kind == "float" else ""
        if nan:
            self.used.libm = True
        accumulate = self.accumulate(function, arg)
        body += [
            "{",
            *(f"    {s}" for s in argument.statements(" ".join([arg.present, *accumulate]))),
            f"    if (!({arg.present}){nan}) continue;",
            "    any = 1;",
            "    s = (int32_t)((r->t - base) / I);",
            f"    if (s < {self.lo(depth)}) continue;",
        ]
        lo = self.lo(depth)
        self.lines += [
            f"/* {out.index}: {function} */",
            "any = 0;",
            "for (s = 0; s < n; s++) cnt[s] = 0;",
            *self.over_rows([*body, *(f"    {a}" for a in accumulate), "}"]),
        ]
        if function == "stddev":
            self.lines += self.variance(body, arg)
        least = 2 if function == "stddev" else 1
        self.lines += [
            "for (s = 0; s < n; s++)",
            f"    sp[{out.index}][s] = (uint8_t)(s >= {lo} && cnt[s] >= {least});",
            f"for (s = {lo}; s < n; s++) {{",
            f"    if (!sp[{out.index}][s]) continue;",
            f"    {self.result(function, arg, out)}",
            "}",
        ]
        self.lines += self.fill(call, out, lo)
        return out

    def accumulate(self, function: str, arg: Value) -> list[str]:
        m, v = _MEMBER[arg.kind], arg.value
        if function == "count":
            return ["cnt[s]++;"]
        if function == "mean":  # the sum over the count, as InfluxDB's mean
            return ["if (!cnt[s]++) a[s].f = 0.0;", f"a[s].f += (double){v};"]
        if function == "stddev":  # a running mean first, as InfluxDB's stddev
            return ["if (!cnt[s]++) a[s].f = 0.0;",
                    f"a[s].f += ((double){v} - a[s].f) / (double)cnt[s];"]  # fmt: skip
        if function == "sum":
            if arg.kind == "int":
                self.used.helpers |= {"add", "i64"}
                return ["if (!cnt[s]++) a[s].i = 0;", f"a[s].i = rmv_add(a[s].i, {v});"]
            return ["if (!cnt[s]++) a[s].f = 0.0;", f"a[s].f = a[s].f + {v};"]
        if function == "first":
            return [f"if (!cnt[s]++) a[s].{m} = {v};"]
        if function == "last":
            return ["cnt[s]++;", f"a[s].{m} = {v};"]
        if function in ("min", "max"):
            better = "<" if function == "min" else ">"
            return [f"if (!cnt[s]++ || {v} {better} a[s].{m}) a[s].{m} = {v};"]
        # spread: the greatest in a, the least in b
        return [
            f"if (!cnt[s]++) {{ a[s].{m} = {v}; b[s].{m} = {v}; }}",
            f"if ({v} > a[s].{m}) a[s].{m} = {v};",
            f"if ({v} < b[s].{m}) b[s].{m} = {v};",
        ]

    def over_rows(self, body: list[str]) -> list[str]:
        """A loop over the rows of the run's range (and its lookback), oldest first."""
        return [
            "for (k = 0; k < count; k++) {",
            "    const rmv_row *r = ROW(k);",
            "    if (r->t < lowest) continue;",
            "    if (r->t >= end) break;",
            *(f"    {line}" for line in body),
            "}",
        ]

    def variance(self, body: list[str], arg: Value) -> list[str]:
        """stddev's second pass: the squares of the differences from the mean, summed
        in the rows' order."""
        self.used.libm = True
        square = [
            "    {",
            f"        const double d = (double){arg.value} - a[s].f;",
            "        b[s].f += d * d;",
            "    }",
            "}",
        ]
        return ["for (s = 0; s < n; s++) b[s].f = 0.0;", *self.over_rows([*body, *square])]

    def result(self, function: str, arg: Value, out: Series) -> str:
        target = f"sv[{out.index}][s].{_MEMBER[out.kind]}"
        m = _MEMBER[arg.kind]
        if function == "count":
            return f"{target} = cnt[s];"
        if function == "stddev":
            return f"{target} = sqrt(b[s].f / (double)(cnt[s] - 1));"
        if function == "mean":
            return f"{target} = a[s].f / (double)cnt[s];"
        if function == "spread":
            if arg.kind == "int":
                self.used.helpers |= {"sub", "i64"}
                return f"{target} = rmv_sub(a[s].i, b[s].i);"
            return f"{target} = a[s].f - b[s].f;"
        return f"{target} = a[s].{m};"

    def fill(self, call: ir.Call, out: Series, lo: int) -> list[str]:
        """_fill over the windows of this depth, where the run read any point."""
        fill = self.event.fill
        member = _MEMBER[out.kind]
        j = out.index
        if fill.mode in ("none", "null"):
            return []
        if fill.mode == "number":
            assert fill.value is not None
            number = number_value(fill.value)
            kind = call.type.kind
            if kind == "int":
                constant = c_int(int(number))
            elif kind in ("float", "time", "duration"):
                if not math.isfinite(float(number)):
                    raise Unsupported("a fill that is not finite")
                constant = c_double(float(number))
                self.used.floats = True
            else:
                return []
            if _MEMBER.get(kind) != member:
                raise Unsupported(f"a fill of a {kind} into a {out.kind}")
            return [
                f"if (any) for (s = {lo}; s < n; s++)",
                f"    if (!sp[{j}][s]) {{ sp[{j}][s] = 1; sv[{j}][s].{member} = {constant}; }}",
            ]
        if fill.mode == "previous":
            return [
                f"if (any) for (s = {lo} + 1; s < n; s++)",
                f"    if (!sp[{j}][s] && sp[{j}][s - 1]) {{",
                f"        sp[{j}][s] = 1;",
                f"        sv[{j}][s] = sv[{j}][s - 1];",
                "    }",
            ]
        # linear: between real neighbours only; windows are whole intervals apart
        self.used.floats = True
        if out.kind == "int":
            self.used.helpers |= {"to_int", "i64"}
        as_double = f"(double)sv[{j}][{{}}].{member}"
        value = f"slope * (double)(s - last) + {as_double.format('last')}"
        store = f"rmv_to_int({value})" if out.kind == "int" else value
        return [
            "if (any) {",
            "    int32_t last = -1, next;",
            f"    for (s = 0; s < n; s++) real[s] = sp[{j}][s];",
            f"    for (s = {lo}; s < n; s++) {{",
            "        if (real[s]) {",
            "            last = s;",
            "            continue;",
            "        }",
            "        if (last < 0) continue;",
            "        for (next = s + 1; next < n && !real[next]; next++) {}",
            "        if (next == n) break;",
            "        {",
            f"            const double to = {as_double.format('next')};",
            f"            const double rise = to - {as_double.format('last')};",
            "            const double slope = rise / (double)(next - last);",
            f"            sp[{j}][s] = 1;",
            f"            sv[{j}][s].{member} = {store};",
            "        }",
            "    }",
            "}",
        ]

    def points(self, top: Series) -> None:
        """The run's points: windows of its range with a value (NaN is none), then
        `limit` (the first N, or the last N with `order desc`)."""
        nan = f" || !isfinite(sv[{top.index}][s].f)" if top.kind == "float" else ""
        if nan:
            self.used.libm = True
        limit = self.event.limit
        self.lines += [
            "points = 0;",
            f"for (s = {self.depth}; s < n; s++) {{",
            f"    if (!sp[{top.index}][s]{nan}) continue;",
            "    out_t[points] = base + s * I;",
            f"    out_v[points] = sv[{top.index}][s];",
            "    points++;",
            "}",
        ]
        if limit is not None and self.event.order == "desc":
            self.lines += [
                f"if (points > {limit}) {{",
                f"    memmove(out_t, out_t + points - {limit}, {limit} * sizeof *out_t);",
                f"    memmove(out_v, out_v + points - {limit}, {limit} * sizeof *out_v);",
                f"    points = {limit};",
                "}",
            ]
        elif limit is not None:
            self.lines.append(f"if (points > {limit}) points = {limit};")
