"""The spec's boolean events and transducers as C (docs/c.md, "From values"):
the tables and condition functions that templates/dataflow.c.inc runs, one
instant at a time, as rmvdsl.runtime.dataflow runs its nodes: each in dependency
order, over the items (changes of boolean names, a transducer's state) the nodes
before it wrote at that instant.

The monitor's inputs are the variables and the value events (a query's points,
which the host computes: InfluxDB, or the runtime). A spec whose events or
transducers the C target cannot compute gets no such tables: `Flow.reason` says
why, and the host gives the monitor the propositions instead."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.dataflow import Condition as RuntimeCondition
from rmvdsl.runtime.dataflow import SpecError, dataflow_nodes
from rmvdsl.runtime.dataflow import Transducer as RuntimeTransducer
from rmvdsl.targets.c.cexpr import Compiler
from rmvdsl.targets.c.model import Unsupported
from rmvdsl.targets.c.queries import Query, compile_query, placed

_KINDS = {"bool": "bool", "int": "int", "float": "float"}


@dataclass(frozen=True)
class Source:
    name: str
    kind: str  # bool | int | float
    what: str  # variable | value event


@dataclass(frozen=True)
class Condition:
    name: str
    flag: int  # its boolean name's index
    lines: tuple[str, ...]  # C statements; the last value is `result`
    result: str  # a C expression: 1 where the event holds
    reads_first: int = 0
    reads: tuple[int, ...] = ()  # the boolean names it reads (their pulses re-evaluate it)


@dataclass(frozen=True)
class Transition:
    source: int
    dest: int
    input: int  # a boolean name
    emit: int  # a boolean name, or -1


@dataclass(frozen=True)
class Transducer:
    name: str
    states: tuple[str, ...]
    initial: int
    first: int  # its first transition in the system's table
    transitions: tuple[Transition, ...]


@dataclass(frozen=True)
class Proposition:
    """Where a property's proposition comes from: a boolean name, or a state."""

    flag: int = -1
    transducer: int = -1
    state: int = -1


@dataclass(frozen=True)
class Flow:
    sources: tuple[Source, ...] = ()
    flags: tuple[str, ...] = ()  # boolean events and emitted events
    conditions: tuple[Condition, ...] = ()
    transducers: tuple[Transducer, ...] = ()
    order: tuple[tuple[str, int], ...] = ()  # ("condition" | "transducer", index)
    propositions: tuple[Proposition, ...] = ()
    log: int = 1  # the most items one instant writes
    helpers: frozenset[str] = frozenset()
    floats: bool = False
    libm: bool = False
    reason: str = ""  # why there is no flow ("" when there is one)
    where: str = ""  # the declaration the reason is about
    queries: tuple[Query, ...] = ()  # the value events it computes
    hosted: tuple[tuple[str, str, str], ...] = ()  # the host gives: (event, why, origin)
    value_topics: tuple[int, ...] = ()  # each value's topic (a row is one topic's values)
    value_computed: tuple[int, ...] = ()  # 1 for a query's point
    topics: int = 1
    pending: int = 2  # instants waiting for the queries' points, at most
    slots: int = 1  # a run's windows, at most (scratch)
    series: int = 1
    rows: int = 1  # the windowed queries' rows, in all
    row_most: int = 1  # the most rows one query holds (a window's values, sorted)
    outs: int = 1  # the most points one run writes
    written: int = 1
    streams: int = 1
    lag: int = 0  # ns: how far the queries' final points lag the input, at most

    @property
    def raw_queries(self) -> tuple[Query, ...]:
        return tuple(q for q in self.queries if not q.windowed)

    @property
    def windowed_queries(self) -> tuple[Query, ...]:
        return tuple(q for q in self.queries if q.windowed)

    @property
    def compiled(self) -> bool:
        return not self.reason

    @property
    def reads_count(self) -> int:
        return sum(len(c.reads) for c in self.conditions)


def flow_of(spec: ir.Spec, propositions: tuple[str, ...]) -> Flow:
    """The events and transducers `propositions` come from, as C; or a Flow whose
    `reason` says what the C target cannot compute."""
    try:
        return _Builder(spec).build(propositions)
    except _Refused as refused:
        return Flow(reason=refused.reason, where=refused.where)


class _Refused(Exception):
    def __init__(self, where: str, reason: str) -> None:
        super().__init__(f"{where}: {reason}")
        self.where, self.reason = where, reason


@dataclass
class _Builder:
    spec: ir.Spec
    sources: dict[str, tuple[int, str]] = field(default_factory=dict)
    source_list: list[Source] = field(default_factory=list)
    flag_ids: dict[str, int] = field(default_factory=dict)
    needed: frozenset[str] = frozenset()  # the events, transducers and values the properties read

    def build(self, propositions: tuple[str, ...]) -> Flow:
        spec = self.spec
        self.needed = _needed(spec, propositions)
        for variable in spec.variables:
            if variable.name in self.needed:
                self.add_source(variable.name, variable.type, "variable", variable.origin)
        for event in spec.events:
            if event.name not in self.needed:
                continue
            if event.kind == "value":
                vtype = self.computed_type(event)
                self.add_source(event.name, vtype, "value event", event.origin)
            elif event.window is not None:
                raise _Refused(event.origin, f"event {event.name}: a condition over windows")
            else:
                self.flag_ids[event.name] = len(self.flag_ids)
        for transducer in spec.transducers:
            for name in transducer.emits if transducer.name in self.needed else ():
                self.flag_ids.setdefault(name, len(self.flag_ids))
        conditions, transducers, order = self.nodes()
        queries, hosted = self.queries()
        place = placed(self.spec, queries, tuple(hosted), [s.name for s in self.source_list])
        return Flow(
            sources=tuple(self.source_list),
            flags=tuple(self.flag_ids),
            conditions=tuple(c for c, _ in conditions),
            transducers=tuple(transducers),
            order=tuple(order),
            propositions=tuple(self.proposition(name, transducers) for name in propositions),
            log=_log_bound(
                [t for t in spec.transducers if t.name in self.needed],
                self.flag_ids,
                [c for c, _ in conditions],
            ),
            value_topics=self.value_topics(),
            topics=max(1, len(self.spec.topics) + len(self.source_list)),
            queries=place.queries,
            hosted=place.hosted,
            value_computed=place.value_computed,
            pending=place.pending,
            lag=place.lag,
            slots=place.slots,
            series=place.series,
            rows=place.rows,
            row_most=place.row_most,
            outs=place.outs,
            written=place.written,
            streams=place.streams,
            helpers=place.helpers.union(*(k.helpers for _, k in conditions)),
            floats=place.floats
            or any(k.floats for _, k in conditions)
            or any(s.kind == "float" for s in self.source_list),
            libm=place.libm or any(k.libm for _, k in conditions),
        )

    def value_topics(self) -> tuple[int, ...]:
        """Each value's topic: a variable's own, each value event one of its own."""
        topic_index = {t.name: k for k, t in enumerate(self.spec.topics)}
        variables = {v.name: v for v in self.spec.variables}
        out = []
        for k, source in enumerate(self.source_list):
            variable = variables.get(source.name)
            out.append(topic_index[variable.topic] if variable else len(topic_index) + k)
        return tuple(out)

    def queries(self) -> tuple[list[Query], list[tuple[str, str, str]]]:
        """The value events the monitor computes, and those whose points the host
        gives, with why."""
        variables = {v.name for v in self.spec.variables}
        from_variables = {n: found for n, found in self.sources.items() if n in variables}
        queries: list[Query] = []
        hosted: list[tuple[str, str, str]] = []
        streams = 0
        for event in self.spec.events:
            if event.name not in self.needed or event.kind != "value":
                continue
            try:
                query = compile_query(event, self.sources[event.name][0], from_variables, streams)
            except Unsupported as error:
                hosted.append((event.name, str(error), event.origin))
                continue
            streams += query.streams
            queries.append(query)
        return queries, hosted

    def computed_type(self, event: ir.Event) -> ir.ValueType:
        """A value event's type, or, for a time or duration the monitor computes
        (`elapsed`: whole units), the kind of what it computes."""
        if event.type.kind in _KINDS:
            return event.type
        variables = {v.name for v in self.spec.variables}
        sources = {n: found for n, found in self.sources.items() if n in variables}
        try:
            return replace(event.type, kind=compile_query(event, 0, sources, 0).kind)
        except Unsupported:
            return event.type

    def add_source(self, name: str, vtype: ir.ValueType, what: str, origin: str) -> None:
        kind = _KINDS.get(vtype.kind)
        if kind is None:
            raise _Refused(
                origin, f"{what} {name}: a {vtype.kind}; the C monitor reads numbers and bools"
            )
        self.sources[name] = (len(self.source_list), kind)
        self.source_list.append(Source(name, kind, what))

    def nodes(
        self,
    ) -> tuple[list[tuple[Condition, Compiler]], list[Transducer], list[tuple[str, int]]]:
        """Conditions and transducers in the runtime's dependency order."""
        try:
            runtime_nodes = dataflow_nodes(self.spec)
        except SpecError as error:
            raise _Refused("", str(error)) from None
        events = {e.name: e for e in self.spec.events}
        by_name = {t.name: t for t in self.spec.transducers}
        conditions: list[tuple[Condition, Compiler]] = []
        transducers: list[Transducer] = []
        order: list[tuple[str, int]] = []
        reads_first = first = 0
        for node in runtime_nodes:
            if node.name not in self.needed:
                continue
            if isinstance(node, RuntimeCondition):
                condition, compiler = self.condition(events[node.name], reads_first)
                reads_first += len(condition.reads)
                order.append(("condition", len(conditions)))
                conditions.append((condition, compiler))
            elif isinstance(node, RuntimeTransducer):
                transducer = self.transducer(by_name[node.name], first)
                first += len(transducer.transitions)
                order.append(("transducer", len(transducers)))
                transducers.append(transducer)
        return conditions, transducers, order

    def condition(self, event: ir.Event, reads_first: int) -> tuple[Condition, Compiler]:
        compiler = Compiler(self.sources, self.flag_ids)
        try:
            holds = compiler.expr(event.expr)
            result = f"{holds.present} && {holds.value}"
            if event.where is not None:
                where = compiler.expr(event.where)
                result = f"{where.present} && {where.value} && {result}"
        except Unsupported as error:
            raise _Refused(event.origin, f"event {event.name}: {error}") from None
        reads = tuple(dict.fromkeys(compiler.flags))
        lines = tuple(compiler.statements(result))
        condition = Condition(
            event.name, self.flag_ids[event.name], lines, result, reads_first, reads
        )
        return condition, compiler

    def transducer(self, transducer: ir.Transducer, first: int) -> Transducer:
        state = {name: k for k, name in enumerate(transducer.states)}
        transitions = []
        for t in transducer.transitions:
            if t.input not in self.flag_ids:
                raise _Refused(t.origin, f"transducer {transducer.name}: the input {t.input}")
            emit = -1 if t.emit is None else self.flag_ids[t.emit]
            transitions.append(
                Transition(state[t.source], state[t.dest], self.flag_ids[t.input], emit)
            )
        return Transducer(
            transducer.name, transducer.states, state[transducer.initial], first, tuple(transitions)
        )

    def proposition(self, name: str, transducers: list[Transducer]) -> Proposition:
        """`transducers`: in the order of the C tables (dependency order)."""
        if name in self.flag_ids:
            return Proposition(flag=self.flag_ids[name])
        for index, transducer in enumerate(transducers):
            if name in transducer.states:
                return Proposition(transducer=index, state=transducer.states.index(name))
        raise _Refused("", f"the proposition {name}")


def _needed(spec: ir.Spec, propositions: tuple[str, ...]) -> frozenset[str]:
    """What the propositions are computed from: their events and transducers (a
    state stands for its transducer), what those read, and so on."""
    reads: dict[str, tuple[str, ...]] = {e.name: e.reads for e in spec.events}
    for transducer in spec.transducers:
        reads[transducer.name] = tuple(t.input for t in transducer.transitions)
        for state in transducer.states:
            reads[state] = (transducer.name,)
        for name in transducer.emits:
            reads[name] = (transducer.name,)
    found: set[str] = set()
    stack = list(propositions)
    while stack:
        name = stack.pop()
        if name not in found:
            found.add(name)
            stack.extend(reads.get(name, ()))
    return frozenset(found)


def _log_bound(
    transducers: list[ir.Transducer], flag_ids: dict[str, int], conditions: list[Condition]
) -> int:
    """The most items one instant writes: a transducer its state once and each
    emitting transition's pulse (a true item and a false one); a condition an item
    at each evaluation, one per pulse of the names it reads, and the last."""
    items: dict[int, int] = {}
    for transducer in transducers:
        for t in transducer.transitions:
            if t.emit is not None:
                items[flag_ids[t.emit]] = items.get(flag_ids[t.emit], 0) + 2
    total = sum(items.values()) + len(transducers)
    for condition in conditions:  # in dependency order: what it reads is counted
        items[condition.flag] = 1 + sum(items.get(flag, 0) for flag in condition.reads)
        total += items[condition.flag]
    return max(1, total)
