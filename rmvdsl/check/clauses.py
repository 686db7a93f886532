"""Events (names stage): each event's expression and InfluxQL clauses (where,
group by, fill, order, limit, resample, range), and events defined in a cycle."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from fractions import Fraction

from rmvdsl.check.model import EVENT_KINDS, Kind, Model, Symbol
from rmvdsl.grammar import ast, printer
from rmvdsl.grammar import formula as fm
from rmvdsl.lang import builtins
from rmvdsl.lang.diagnostics import Diagnostic, did_you_mean, error, warning
from rmvdsl.lang.source import Span
from rmvdsl.runtime.functions import STREAMS

INFLUX_FUNCTIONS = builtins.FUNCTIONS
FILL_NAMES = builtins.FILLS


_AGGREGATING = ("aggregation", "selector")


NANOSECOND = Fraction(1, 10**9)
COSTLY_BELOW = Fraction(1, 1000)  # windows and runs shorter than this warn (RMV223)


def _group(call: ast.Call) -> str | None:
    found = INFLUX_FUNCTIONS.get(call.func.name)
    return found.group if found else None


def _aggregated(node: ast.Node) -> bool:
    """Whether an aggregate or selector call is inside node (or is node)."""
    return any(isinstance(n, ast.Call) and _group(n) in _AGGREGATING for n in ast.walk(node))


def _bare_reference(expr: ast.Node) -> ast.NameRef | None:
    """The first name read outside every aggregate or selector call."""
    stack = [expr]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.NameRef):
            return node
        if isinstance(node, ast.Call) and _group(node) in _AGGREGATING:
            continue
        stack.extend(reversed(list(node.children())))
    return None


def _field_or_constant(node: ast.Node) -> bool:
    if isinstance(node, ast.UnaryOp) and node.op == "-":
        return isinstance(node.operand, ast.NumberLit)
    return isinstance(node, ast.NameRef | ast.NumberLit | ast.TimeLit)


class EventChecks:
    """The names stage's checks of events (a part of NameChecker)."""

    model: Model
    diagnostics: list[Diagnostic]
    # The names each event reads (its expression and `where` clauses), found while
    # checking it: the cycle check (rmvdsl.check.cycles) reads them rather than
    # walking every event again.
    event_reads: dict[int, Sequence[ast.Ident]]  # by id() of the declaration

    def report(self, diagnostic: Diagnostic) -> None:
        self.diagnostics.append(diagnostic)

    # NameChecker's, which this class is a part of.
    resolve: Callable[[ast.Ident, frozenset[Kind], str], Symbol | None]
    once_only: Callable[..., None]

    def check_event(self, decl: ast.EventDecl) -> None:
        allowed = frozenset({Kind.VARIABLE, *EVENT_KINDS})
        nodes = self.check_expression(decl.expr, allowed)
        calls = [n for n in nodes if isinstance(n, ast.Call)]
        seen: dict[str, ast.Clause] = {}
        conditions = [call for call in calls if decl.boolean and decl.clause("group") is None]
        where: list[ast.Call] = []
        for clause in decl.clauses:
            first = seen.setdefault(clause.kind, clause)
            if first is not clause:
                self.once_only(f"the `{clause.kind}` clause of `{decl.name.name}`", clause, first)
            found = self.check_clause(clause, allowed)
            if clause.kind == "where":
                where += [n for n in found if isinstance(n, ast.Call)]
            nodes += found
        self.event_reads[id(decl)] = [n.ident for n in nodes if isinstance(n, ast.NameRef)]
        if self.check_series_in_condition(decl, [*conditions, *where]) and self.check_where_calls(
            decl, where
        ):
            self.check_query_shape(decl, calls)

    def check_series_in_condition(self, decl: ast.EventDecl, calls: list[ast.Call]) -> bool:
        """A condition is evaluated over the newest value of each name it reads, so it
        may transform a value (`abs(V) > 3`) but not a series of points (RMV321);
        `calls`: those of its conditions. Whether it was fine."""
        for call in calls:
            name = call.func.name
            if name in STREAMS:
                event = decl.name.name + name.title().replace("_", "")
                self.report_shape(
                    call.func.span,
                    f"`{name}` in a condition of `{decl.name.name}` needs a series of "
                    "points, and a condition reads the newest value of each name",
                    "a transformation of a series",
                    f"declare it as a value event, `event {event} = "
                    f"{printer.expression(call)}`, and compare `{event}`",
                )
                return False
        return True

    def check_where_calls(self, decl: ast.EventDecl, calls: list[ast.Call]) -> bool:
        """InfluxDB's WHERE applies a function to fields and constants only: over
        anything else (`abs(x - 3)`) it matches no row, and it has no `log` with a
        base (RMV321). `calls`: those of the `where` clause. Whether it was fine."""
        for call in calls:
            name = call.func.name
            if name == "log" and len(call.args) == 2:  # other counts: RMV314, types stage
                value, base = (printer.expression(a) for a in call.args)
                self.report_shape(
                    call.func.span,
                    f"InfluxDB's WHERE has no `log` with a base: `{printer.expression(call)}`"
                    " is refused there",
                    "refused by InfluxDB",
                    f"divide natural logarithms: `ln({value}) / ln({base})`",
                )
                return False
            for argument in call.args:
                if not _field_or_constant(argument):
                    self.report_shape(
                        argument.span,
                        f"InfluxDB's WHERE applies `{name}` to a field or a constant only: "
                        f"`{printer.expression(call)}` matches no row there",
                        "not a field or a constant",
                        f"apply `{name}` to the value itself, as in `{name}(x) > 1`, or write"
                        " the condition without it",
                    )
                    return False
        return True

    def check_query_shape(self, decl: ast.EventDecl, calls: list[ast.Call]) -> None:
        """What InfluxQL refuses in a continuous query, and the runtime cannot run:
        an aggregate without `group by time`, `group by time` without one, a
        transformation over windows with no aggregate inside, and a bare value
        beside an aggregate (RMV321); `calls` are those of its expression."""
        group = decl.clause("group")
        aggregates = [c for c in calls if _group(c) in _AGGREGATING]
        name = decl.name.name
        if aggregates and group is None:
            self.report_shape(
                aggregates[0].func.span,
                f"`{name}` aggregates with `{aggregates[0].func.name}` but has no window",
                "an aggregate over no `group by time(...)`",
                "add `group by time(1s)` (or the window the event needs)",
            )
            return
        if group is None:
            return
        for call in calls:
            if _group(call) == "transformation" and call.args and not _aggregated(call.args[0]):
                self.report_shape(
                    call.func.span,
                    f"`{call.func.name}` over windows needs an aggregate inside",
                    "a transformation of raw values beside `group by time`",
                    f"write `{call.func.name}(mean(...))` or another aggregate",
                )
                return
        if not aggregates:
            self.report_shape(
                group.span,
                f"`{name}` is grouped by time but aggregates nothing",
                "`group by time` needs an aggregate such as `mean(x)`",
                "aggregate each value (`mean(x)`, `last(x)`) or remove the clause",
            )
            return
        bare = _bare_reference(decl.expr)
        if bare is not None:
            self.report_shape(
                bare.span,
                f"`{bare.ident.name}` is used raw beside an aggregate in `{name}`",
                "not inside an aggregate",
                f"aggregate it as the window needs, e.g. `last({bare.ident.name})`",
            )
            return
        self.check_resample_span(decl, group)

    def check_resample_span(self, decl: ast.EventDecl, group: ast.Clause) -> None:
        """InfluxDB refuses a continuous query that reads less than one window per
        run ("FOR duration must be >= GROUP BY time duration")."""
        resample = decl.clause("resample")
        if resample is None or not isinstance(resample.value, ast.Resample):
            return
        span = resample.value.for_
        interval = group.value.interval if isinstance(group.value, ast.GroupBy) else None
        if span is None or interval is None:
            return
        reads, window = span.time.seconds(), interval.time.seconds()
        if reads is not None and window is not None and reads < window:
            self.report_shape(
                span.span,
                f"`{decl.name.name}` reads {span.time.text} per run, less than its "
                f"{interval.time.text} window: InfluxDB refuses the continuous query",
                "shorter than the window",
                f"write `for {interval.time.text}` or longer",
            )

    def report_shape(self, span: Span, message: str, label: str, help: str) -> None:
        self.report(error("RMV321", message, span, label=label, help=help))

    def check_clause(self, clause: ast.Clause, allowed: frozenset[Kind]) -> list[ast.Node]:
        """Checks a clause; returns the nodes of its expression (`where`'s)."""
        value = clause.value
        match clause.kind:
            case "where":
                return self.check_expression(value, allowed)
            case "group":
                assert isinstance(value, ast.GroupBy)
                for time in (value.interval, value.offset):
                    if time is not None:
                        self.check_positive_time(
                            time.time, "group-by interval", allow_zero=time is value.offset
                        )
                if value.interval is not None:
                    self.check_cost(value.interval.time, "window")
            case "fill":
                self.check_fill(value)
            case "order":
                assert isinstance(value, ast.NameValue)
                if value.ident.name.lower() not in builtins.ORDERS:
                    self.invalid_clause(value, "`order` is `asc` or `desc`", builtins.ORDERS)
            case "limit":
                if not (
                    isinstance(value, ast.NumberLit)
                    and value.value.denominator == 1
                    and value.value > 0
                ):
                    self.invalid_clause(value, "`limit` is a positive whole number", ())
            case "resample":
                assert isinstance(value, ast.Resample)
                for time in (value.every, value.for_):
                    if time is not None:
                        self.check_positive_time(time.time, "resample interval")
                if value.every is not None:
                    self.check_cost(value.every.time, "query run")
            case "range":
                assert isinstance(value, ast.TimeLit)
                self.check_positive_time(value.time, "range")
        return []

    def check_fill(self, value: ast.Node) -> None:
        if isinstance(value, ast.NameValue):
            if value.ident.name not in FILL_NAMES:
                self.invalid_clause(
                    value, "`fill` is none, null, previous, linear or a number", FILL_NAMES
                )
        elif not isinstance(value, ast.NumberLit):
            self.invalid_clause(
                value, "`fill` is none, null, previous, linear or a number", FILL_NAMES
            )

    def invalid_clause(self, value: ast.Node, expected: str, choices: Iterable[str]) -> None:
        found = value.ident.name if isinstance(value, ast.NameValue) else ""
        self.report(
            error(
                "RMV208",
                "invalid clause value",
                value.span,
                label=expected,
                help=did_you_mean(found, choices) if found else None,
            )
        )

    def check_positive_time(self, time: fm.TimeValue, what: str, allow_zero: bool = False) -> None:
        if time.unit is None:
            self.report(
                error(
                    "RMV213",
                    f"the {what} `{time.text}` has no unit",
                    time.span,
                    label="a time needs a unit here",
                    help=f"write `{time.text}s` or `{time.text}ms`",
                )
            )
        elif time.value < 0 or (time.value == 0 and not allow_zero):
            self.report(
                error("RMV219", f"the {what} must be positive", time.span, label=f"`{time.text}`")
            )
        elif 0 < (time.seconds() or 0) < NANOSECOND:
            self.report(
                error(
                    "RMV219",
                    f"the {what} must be at least 1ns",
                    time.span,
                    label=f"`{time.text}` is 0 whole nanoseconds",
                    help="times are whole nanoseconds, as InfluxDB's: write `1ns` or more",
                )
            )

    def check_cost(self, time: fm.TimeValue, what: str) -> None:
        """A window or run shorter than COSTLY_BELOW: the runtime (and InfluxDB)
        compute one per interval of input time, so a replay takes that many per
        second of recording."""
        seconds = time.seconds()
        if seconds is None or not NANOSECOND <= seconds < COSTLY_BELOW:
            return
        per_second = round(1 / seconds)
        self.report(
            warning(
                "RMV223",
                f"a {what} every {time.text} is {per_second:,} per second of input",
                time.span,
                label=f"{per_second * 3600:,} for an hour's recording",
                help="use a window of 1ms or more; for every message, drop the window",
            )
        )

    def check_expression(self, expr: ast.Node, allowed: frozenset[Kind]) -> list[ast.Node]:
        """Resolves the names an expression reads; returns its nodes."""
        nodes = ast.walk(expr)
        for node in nodes:
            if isinstance(node, ast.NameRef):
                self.resolve(node.ident, allowed, "a variable or an event")
            elif isinstance(node, ast.Call) and node.func.name not in INFLUX_FUNCTIONS:
                self.report(
                    error(
                        "RMV215",
                        f"unknown function `{node.func.name}`",
                        node.func.span,
                        label="not an InfluxQL function",
                        help=did_you_mean(node.func.name, INFLUX_FUNCTIONS)
                        or "see `rmv explain RMV215` for the supported functions",
                    )
                )
        return nodes
