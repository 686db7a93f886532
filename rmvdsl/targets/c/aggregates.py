"""The aggregates and selectors of a windowed query's run as C: each window's
value from the rows of the run, as rmvdsl.runtime.functions.reduce and
fill.integral compute it (docs/c.md, "Queries"). RunBody is the run function's
body: the series it computes and the loops over its rows."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.expressions import number_value
from rmvdsl.targets.c.cexpr import Value, c_double, c_int
from rmvdsl.targets.c.model import Unsupported
from rmvdsl.targets.c.rows import MEMBER, Compiled, RowCompiler, row_compiler, unit_of

# The aggregations and selectors C computes, and the kind of what each gives
# ("": the kind of what it reads).
AGGREGATES = {"count": "int", "sum": "", "mean": "float", "min": "", "max": "", "first": "",
              "last": "", "spread": "", "stddev": "float", "median": "float", "percentile": "",
              "mode": "", "integral": "float"}  # fmt: skip
# Those that read a window's values in order (value, then time): sorted in place.
_SORTED = frozenset({"median", "percentile", "mode"})
# Those that read the run's points in time order, across windows: kept as they come.
_KEPT = _SORTED | {"integral"}


@dataclass(frozen=True)
class Series:
    index: int  # sp[index][slot], sv[index][slot]
    kind: str


@dataclass
class RunBody:
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

    def row_value(self, expr: ir.Expr) -> tuple[Value, list[str], RowCompiler]:
        """An expression of a row: its value, the lines of `where` that go on to
        the next row where it does not hold, and the compiler of the value."""
        where: list[str] = []
        if self.event.where is not None:
            compiler = row_compiler(self.sources)
            holds = compiler.expr(self.event.where)
            self.used.take(compiler)
            test = f"{holds.present} && {holds.value}"
            where = ["{", *(f"    {s}" for s in compiler.statements(test)),
                     f"    if (!({test})) continue;", "}"]  # fmt: skip
        argument = row_compiler(self.sources)
        arg = argument.expr(expr)
        self.used.take(argument)
        return arg, where, argument

    def checked(
        self, where: list[str], argument: RowCompiler, arg: Value, uses: list[str]
    ) -> list[str]:
        """A loop body's first lines: `where`, the value (the next row where it has
        none, or a NaN or an infinity: InfluxDB stores neither), its window `s`.
        `uses`: the lines after it that read it."""
        nan = f" || !isfinite({arg.value})" if arg.kind == "float" else ""
        if nan:
            self.used.libm = True
        return [
            *where,
            "{",
            *(f"    {s}" for s in argument.statements(" ".join([arg.present, *uses]))),
            f"    if (!({arg.present}){nan}) continue;",
            "    any = 1;",
            "    s = (int32_t)((r->t - base) / I);",
        ]

    def aggregate(self, call: ir.Call, depth: int) -> Series:
        """AGGREGATES over the rows of each window (reduce); `fill` comes after."""
        self.aggregated = True
        function = call.function
        arg, where, argument = self.row_value(call.args[0])
        if arg.kind not in ("int", "float") and function != "count":
            raise Unsupported(f"`{function}` of a {arg.kind}")
        kind = AGGREGATES[function] or arg.kind
        if "float" in (kind, arg.kind):
            self.used.floats = True
        out = self.new(kind)
        sort = function in _KEPT
        accumulate = self.collect(arg) if sort else self.accumulate(function, arg)
        body = [
            *self.checked(where, argument, arg, accumulate),
            # integral interpolates across windows: it reads the lookback's points too
            *([f"    if (s < {self.lo(depth)}) continue;"] if function != "integral" else []),
        ]
        lo = self.lo(depth)
        self.lines += [
            f"/* {out.index}: {function} */",
            "any = 0;",
            "got = 0;" if sort else "for (s = 0; s < n; s++) cnt[s] = 0;",
            *self.over_rows([*body, *(f"    {a}" for a in accumulate), "}"]),
        ]
        if function == "integral":
            self.lines += self.integral(call, arg, out, lo)
            return out
        if sort:
            self.lines += self.sorted_result(call, arg, out)
            return out
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
        return out

    def collect(self, arg: Value) -> list[str]:
        """A window's values kept with their times and windows (rows come in time
        order: each window's are together)."""
        self.used.helpers.add("keep")
        return ["qslot[got] = s;", f"qval[got].{MEMBER[arg.kind]} = {arg.value};",
                "qtime[got] = r->t;", "got++;"]  # fmt: skip

    def sorted_result(self, call: ir.Call, arg: Value, out: Series) -> list[str]:
        """median, percentile and mode of each window's values sorted by value, then
        time (functions._median, _percentile, _mode)."""
        j, m, function = out.index, MEMBER[arg.kind], call.function
        self.used.helpers.add("sort")
        head = [
            f"for (s = 0; s < n; s++) sp[{j}][s] = 0;",
            "for (g = 0; g < got; g = h) {",
            "    int32_t c;",
            "    for (h = g; h < got && qslot[h] == qslot[g]; h++) {}",
            "    c = h - g;",
            "    s = qslot[g];",
            f"    rmv_sort(qval + g, qtime + g, c, '{arg.kind[0]}');",
            f"    sp[{j}][s] = 1;",
        ]
        if function == "median":
            self.used.floats = True
            high, low = "qval[g + c / 2]", "qval[g + c / 2 - 1]"
            # the exact difference of two int64s, sorted, fits in a uint64
            diff = (
                f"(double)((uint64_t){high}.i - (uint64_t){low}.i)"
                if arg.kind == "int"
                else f"({high}.f - {low}.f)"
            )
            body = [
                f"    if (c % 2) sv[{j}][s].f = (double){high}.{m};",
                f"    else sv[{j}][s].f = (double){low}.{m} + {diff} / 2;",
            ]
        elif function == "percentile":
            self.used.floats = self.used.libm = True
            percent = c_double(float(number_value(call.args[1])))  # type: ignore[arg-type]
            body = [
                "    {",
                f"        const double at = floor((double)c * {percent} / 100.0 + 0.5);",
                "        if (at < 1 || at > c) sp[" + str(j) + "][s] = 0;",
                f"        else sv[{j}][s] = qval[g + (int32_t)at - 1];",
                "    }",
            ]
        else:  # mode: InfluxDB's loop, exactly
            body = [
                "    {",
                "        int64_t most_freq = 0, current_freq = 0;",
                "        int64_t current_time = qtime[g], most_time = qtime[g];",
                "        rmv_value current = qval[g], most = qval[g];",
                "        int32_t i;",
                "        for (i = g; c > 1 && i < h; i++) {",
                f"            if (qval[i].{m} != current.{m}) {{",
                "                current_freq = 1;",
                "                current = qval[i];",
                "                current_time = qtime[i];",
                "                continue;",
                "            }",
                "            current_freq++;",
                "            if (most_freq > current_freq",
                "                || (most_freq == current_freq && current_time > most_time))",
                "                continue;",
                "            most_freq = current_freq;",
                "            most = qval[i];",
                "            most_time = current_time;",
                "        }",
                f"        sv[{j}][s] = most;",
                "    }",
            ]
        return [*head, *body, "}"]

    def integral(self, call: ir.Call, arg: Value, out: Series, lo: int) -> list[str]:
        """InfluxDB's integral reducer over the run's points in time order
        (fill.integral): trapezoids, the area up to a window's end interpolated
        onto the next point, each window's sum written at its start."""
        self.used.floats = True
        j, m = out.index, MEMBER[arg.kind]
        unit = f"(double){c_int(unit_of(call))}"
        return [
            f"for (s = 0; s < n; s++) sp[{j}][s] = 0;",
            "if (got) {",
            "    int64_t prev_t = qtime[0], w_end;",
            f"    double prev_v = (double)qval[0].{m}, total = 0.0;",
            "    int32_t w = qslot[0];",
            "    w_end = base + (int64_t)(w + 1) * I;",
            "    for (k = 1; k < got; k++) {",
            "        const int64_t t = qtime[k];",
            f"        const double v = (double)qval[k].{m};",
            "        if (t == prev_t) {",
            "            prev_v = v;",
            "            continue;",
            "        }",
            "        if (t >= w_end) {",
            "            if (prev_t != w_end) {",
            "                const double at_end = prev_v + (v - prev_v) / (double)(t - prev_t)"
            " * (double)(w_end - prev_t);",
            f"                const double part = (double)(w_end - prev_t) / {unit};",
            "                total += 0.5 * (at_end + prev_v) * part;",
            "                prev_t = w_end;",
            "                prev_v = at_end;",
            "            }",
            f"            if (w >= {lo} && w < n) {{",
            f"                sp[{j}][w] = 1;",
            f"                sv[{j}][w].f = total;",
            "            }",
            "            w = qslot[k];",
            "            w_end = base + (int64_t)(w + 1) * I;",
            "            total = 0.0;",
            "        }",
            f"        total += 0.5 * (v + prev_v) * ((double)(t - prev_t) / {unit});",
            "        prev_t = t;",
            "        prev_v = v;",
            "    }",
            f"    if (prev_t != base + (int64_t)w * I && w >= {lo} && w < n) {{",
            f"        sp[{j}][w] = 1;",
            f"        sv[{j}][w].f = total;",
            "    }",
            "}",
        ]

    def accumulate(self, function: str, arg: Value) -> list[str]:
        m, v = MEMBER[arg.kind], arg.value
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
        target = f"sv[{out.index}][s].{MEMBER[out.kind]}"
        m = MEMBER[arg.kind]
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
