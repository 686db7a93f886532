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

from collections.abc import Mapping
from dataclasses import dataclass, replace
from fractions import Fraction

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.functions import MULTI
from rmvdsl.runtime.influx import LOOKBACK
from rmvdsl.runtime.series import nanoseconds
from rmvdsl.targets.c.model import Unsupported
from rmvdsl.targets.c.rows import MEMBER, Compiled, row_compiler
from rmvdsl.targets.c.windows import WindowRun


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
    origin: str = ""  # its declaration
    multi: bool = False  # top, bottom, distinct: several points a window
    outs: int = 1  # the most points a run writes

    @property
    def member(self) -> str:
        return MEMBER[self.kind]

    @property
    def lag(self) -> int:
        """How far the time its points are final lags the input's (ns):
        rmvdsl.runtime.influx.EventState.final_before is at most a run's span and
        a window behind."""
        return self.span + self.interval


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
    return replace(query, used=used, origin=event.origin)


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
    run = WindowRun(event, sources, depth, used)
    if isinstance(event.expr, ir.Call) and event.expr.function in MULTI:
        kind = run.multi(event.expr)
        run.limit()
        return replace(query, kind=kind, lines=tuple(run.lines), slots=slots, multi=True)
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
class Placement:
    """The queries placed in the monitor's pools (Flow's fields of the same names)."""

    queries: tuple[Query, ...]
    hosted: tuple[tuple[str, str, str], ...]  # value events the host gives: why, where
    value_computed: tuple[int, ...]
    pending: int
    lag: int
    slots: int
    series: int
    rows: int
    row_most: int
    outs: int
    written: int
    streams: int
    helpers: frozenset[str]
    floats: bool
    libm: bool


def placed(
    spec: ir.Spec,
    queries: list[Query],
    hosted: tuple[tuple[str, str, str], ...],
    names: list[str],
) -> Placement:
    """The queries placed in the monitor's pools (`names`: the monitor's values). A
    windowed query holds back the instants until its points are final, and holds
    its rows: both are bounded by the topics' max_rate, so each topic the monitor
    reads needs one (else the host gives the windowed queries' points)."""
    topics = {t.name: t for t in spec.topics}
    variables = {v.name: v for v in spec.variables}
    read = {variables[n].topic for n in names if n in variables}
    windowed = [q for q in queries if q.windowed]
    hosted_list = list(hosted)
    missing = sorted(t for t in read if topics[t].max_rate is None)
    others = [name for name, _, _ in hosted_list]
    if windowed and (missing or others):
        why = (
            f"topic {missing[0]} declares no max_rate, which sizes the instants held "
            "until a window's point is final"
            if missing
            else f"it holds instants back for its windows, and {others[0]}'s points, which "
            "the host gives, come at no declared rate"
        )
        hosted_list += [(q.name, why, q.origin) for q in windowed]
        queries = [q for q in queries if not q.windowed]
        windowed = []
    out: list[Query] = []
    rows = written = reads = streams = 0
    for query in queries:
        if query.windowed:
            mine = {variables[names[k]].topic for k in query.reads}
            count = sum(_allowance(topics[t], query.lag + query.lookback) for t in mine) + 1
            # top, bottom and distinct write a point a row at most
            most = count if query.multi else 0
            query = replace(query, rows=count, row_first=rows, written_first=written,
                            reads_first=reads, written=query.written + 2 * most,
                            outs=max(query.slots, most))  # fmt: skip
            rows, written, reads = rows + count, written + query.written, reads + len(query.reads)
        streams += query.streams
        out.append(query)
    lag = max((q.lag for q in windowed), default=0)
    pending = 2
    if windowed:
        pending += sum(_allowance(topics[t], lag) for t in read)
        pending += sum(q.lag // q.interval + 2 for q in windowed)
    computed = {q.name for q in out}
    used = [q.used for q in out if q.used]
    return Placement(
        queries=tuple(out),
        hosted=tuple(hosted_list),
        value_computed=tuple(int(n in computed) for n in names),
        pending=pending,
        lag=lag,
        slots=max((q.slots for q in windowed), default=1),
        series=max((q.series for q in windowed), default=1),
        rows=max(1, rows),
        row_most=max([1, *(q.rows for q in out if q.windowed)]),
        outs=max([1, *(q.outs for q in out if q.windowed)]),
        written=max(1, written),
        streams=max(1, streams),
        helpers=frozenset().union(*(u.helpers for u in used)),
        floats=any(u.floats for u in used),
        libm=any(u.libm for u in used),
    )


def _allowance(topic: ir.Topic, span: int) -> int:
    """The most messages `topic` carries in any `span` ns, from its max_rate
    (docs/runtime.md, "Declared rates": ceil(R x W) in any W = max(1 s, 1/R))."""
    assert topic.max_rate is not None
    window = max(Fraction(1), 1 / topic.max_rate)
    return -(-topic.max_rate * window // 1) * (span // nanoseconds(window) + 1)
