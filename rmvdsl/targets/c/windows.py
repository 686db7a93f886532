"""A windowed query's run as C (WindowedQuery.execute): every subexpression a
series over the run's windows, the streaming transformations and the operators
window by window, `fill`, the points and `limit`; and the selectors of several
points a window (docs/c.md, "Queries")."""

from __future__ import annotations

import math
from dataclasses import replace

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.expressions import number_value
from rmvdsl.runtime.functions import ELEMENTWISE, STREAMS
from rmvdsl.runtime.influx import LOOKBACK
from rmvdsl.targets.c.aggregates import AGGREGATES, RunBody, Series
from rmvdsl.targets.c.cexpr import Compiler, c_double, c_int
from rmvdsl.targets.c.model import Unsupported
from rmvdsl.targets.c.rows import MEMBER, STREAM_CODES, stream_kind, unit_of


class WindowRun(RunBody):
    """The run function's body, from the event's expression down."""

    def series(self, expr: ir.Expr, depth: int) -> Series:
        if isinstance(expr, ir.Call) and expr.function in AGGREGATES:
            out = self.aggregate(expr, depth)
            self.lines += self.fill(expr, out, self.lo(depth))
            return out
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
            f"        sv[{out.index}][s].{MEMBER[value.kind]} = {value.value};",
            "}",
        ]
        return out

    def stream(self, call: ir.Call, depth: int) -> Series:
        code = STREAM_CODES.get(call.function)
        if code is None:
            raise Unsupported(f"`{call.function}` (not computed in C)")
        inner_depth = depth + (1 if call.function in LOOKBACK else 0)
        inner = self.series(call.args[0], inner_depth)
        if inner.kind not in ("int", "float"):
            raise Unsupported(f"`{call.function}` of a {inner.kind}")
        kind = stream_kind(call.function, inner.kind)
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
            f"sv[{inner.index}][s], {c_int(unit_of(call))});",
            f"        if (o.has && s >= {self.lo(depth)}) {{",
            f"            sp[{out.index}][s] = 1;",
            f"            sv[{out.index}][s] = o.v;",
            "        }",
            "    }",
            "}",
        ]
        return out

    def multi(self, call: ir.Call) -> str:
        """top, bottom and distinct (WindowedQuery._multi_points): each window's
        points, chosen; top and bottom at their own times, distinct at the
        window's start. The kind of the points."""
        if call.function == "sample":
            raise Unsupported("`sample` (the runtime's seeded random choice)")
        self.aggregated = True
        arg, where, argument = self.row_value(call.args[0])
        if arg.kind not in ("int", "float"):
            raise Unsupported(f"`{call.function}` of a {arg.kind}")
        if arg.kind == "float":
            self.used.floats = True
        keep = self.collect(arg)
        body = self.checked(where, argument, arg, keep)
        self.lines += [
            f"/* {call.function} */",
            "got = 0;",
            *self.over_rows([*body, *(f"    {a}" for a in keep), "}"]),
            "points = 0;",
            "for (g = 0; g < got; g = h) {",
            "    int32_t c, i;",
            "    for (h = g; h < got && qslot[h] == qslot[g]; h++) {}",
            "    c = h - g;",
        ]
        m = MEMBER[arg.kind]
        if call.function == "distinct":  # each value once, in the order it came
            self.lines += [
                "    for (i = g; i < h; i++) {",
                "        int32_t seen = g;",
                f"        while (seen < i && qval[seen].{m} != qval[i].{m}) seen++;",
                "        if (seen < i) continue;",
                "        out_t[points] = base + (int64_t)qslot[g] * I;",
                "        out_v[points++] = qval[i];",
                "    }",
                "    (void)c;",
                "}",
            ]
            return arg.kind
        self.used.helpers.add("sort")
        order = arg.kind[0].upper() if call.function == "top" else arg.kind[0]
        count = int(number_value(call.args[1]))  # type: ignore[arg-type]
        self.lines += [
            f"    rmv_sort(qval + g, qtime + g, c, '{order}');",
            f"    if (c > {count}) c = {count};",
            "    rmv_sort(qval + g, qtime + g, c, 't');  /* the chosen, by time */",
            "    for (i = g; i < g + c; i++) {",
            "        out_t[points] = qtime[i];",
            "        out_v[points++] = qval[i];",
            "    }",
            "}",
        ]
        return arg.kind

    def fill(self, call: ir.Call, out: Series, lo: int) -> list[str]:
        """_fill over the windows of this depth, where the run read any point."""
        fill = self.event.fill
        member = MEMBER[out.kind]
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
            if MEMBER.get(kind) != member:
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
        self.lines += [
            "points = 0;",
            f"for (s = {self.depth}; s < n; s++) {{",
            f"    if (!sp[{top.index}][s]{nan}) continue;",
            "    out_t[points] = base + s * I;",
            f"    out_v[points] = sv[{top.index}][s];",
            "    points++;",
            "}",
        ]
        self.limit()

    def limit(self) -> None:
        """`limit N` keeps the run's first N points, with `order desc` its last N."""
        limit = self.event.limit
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
