"""Names: declare every symbol, resolve every use, and check each declaration's
structure (stage 2 of the pipeline).

The result is the resolved `Model` and the diagnostics of this stage.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import rmvdsl.check.settings as schemas
from rmvdsl.check.actions import ActionChecks
from rmvdsl.check.clauses import EventChecks
from rmvdsl.check.cycles import event_cycles
from rmvdsl.check.declaring import Declarations
from rmvdsl.check.infrastructure import infrastructure_warnings
from rmvdsl.check.memo import Entry
from rmvdsl.check.model import (
    EVENT_KINDS,
    MEASUREMENT_KINDS,
    Kind,
    Model,
    Reference,
    ReusedReferences,
    Symbol,
)
from rmvdsl.check.rosnames import message_type_problem
from rmvdsl.check.structure import StructureChecks
from rmvdsl.check.whitelists import check_whitelist_agreement, topic_of
from rmvdsl.grammar import ast
from rmvdsl.grammar.grammars import reserved_names
from rmvdsl.grammar.shift import findings
from rmvdsl.lang import builtins
from rmvdsl.lang.diagnostics import Diagnostic, Label, did_you_mean, error, warning
from rmvdsl.lang.source import SourceMap, Span

ARRAY_AGGREGATES = tuple(builtins.ARRAY_AGGREGATES)


@dataclass(frozen=True)
class Resolved:
    """What checking one declaration found when it found nothing wrong: the names
    it looked up (each one's kind and owner then), its references, and an event's
    reads. Spans are where the declaration stood (`start`)."""

    start: int
    lookups: tuple[tuple[str, Kind, str | None], ...]
    references: tuple[tuple[str, Span], ...]
    used: tuple[str, ...]  # the names of its references, once each
    reads: tuple[ast.Ident, ...] | None


class NameChecker(Declarations, StructureChecks, ActionChecks, EventChecks):
    def __init__(
        self,
        specs: list[ast.Spec],
        sources: SourceMap,
        damaged: set[str],
        damaged_ranges: dict[str, list[tuple[int, int]]],
        incremental: bool = False,
    ) -> None:
        self.model = Model(sources, specs, damaged_ranges=damaged_ranges)
        self.incremental = incremental
        # While a declaration's check is remembered: every name it looked up.
        self.lookups: list[tuple[str, Symbol | None]] | None = None
        self.diagnostics: list[Diagnostic] = []
        self.damaged = damaged
        self.damaged_ranges = damaged_ranges
        self.used: set[str] = set()  # the names of used symbols
        self.event_reads: dict[int, Sequence[ast.Ident]] = {}
        self.reads_moved: dict[int, int] = {}  # how far a reused event's reads moved
        self.time_unit_decl: ast.TimeUnitDecl | None = None
        self.reserved = reserved_names()

    # ---- driver ----

    def run(self) -> tuple[Model, list[Diagnostic]]:
        decls = self.model.declarations()
        self.declare_all(decls)
        if self.incremental:
            self.check_all_remembered(decls)
        else:
            for decl in decls:
                self.check_decl(decl)
        self.diagnostics += event_cycles(self.model, self.event_reads, self.reads_moved)
        self.check_whitelist_duplicates()
        self.diagnostics += check_whitelist_agreement(self.model)
        self.diagnostics += infrastructure_warnings(self.model)
        self.report_unused()
        return self.model, self.diagnostics

    # ---- resolving ----

    def resolve(self, ident: ast.Ident, allowed: frozenset[Kind], wanted: str) -> Symbol | None:
        symbol = self.model.symbols.get(ident.name)
        if self.lookups is not None:
            self.lookups.append((ident.name, symbol))
        if symbol is None:
            self.model.unresolved.add(ident.name)
            if ident.name not in self.damaged:
                candidates = [s.name for s in self.model.symbols.values() if s.kind in allowed]
                self.report(
                    error(
                        "RMV200",
                        f"undefined name `{ident.name}`",
                        ident.span,
                        label=f"not declared (expected {wanted})",
                        help=did_you_mean(ident.name, candidates),
                    )
                )
            return None
        self.model.uses.append(Reference(ident.name, ident.span, symbol))
        self.used.add(symbol.name)
        if symbol.kind not in allowed:
            self.report(
                error(
                    "RMV202",
                    f"`{ident.name}` is {symbol.kind.described()}, but {wanted} is needed here",
                    ident.span,
                    label=f"expected {wanted}",
                    secondary=[Label(symbol.span, f"declared as {symbol.kind.described()} here")],
                    help=self.kind_help(symbol, allowed),
                )
            )
            return None
        return symbol

    @staticmethod
    def kind_help(symbol: Symbol, allowed: frozenset[Kind]) -> str | None:
        if symbol.kind is Kind.VALUE_EVENT and Kind.BOOL_EVENT in allowed:
            return (
                f"`{symbol.name}` is a value (`event {symbol.name} = ...`); define a boolean event "
                f"such as `event {symbol.name}High when {symbol.name} > 10`"
            )
        if symbol.kind is Kind.TOPIC and Kind.VARIABLE in allowed:
            return f"declare a variable: `var X = {symbol.name}.field`"
        return None

    # ---- checking each declaration ----

    def check_all_remembered(self, decls: list[ast.Decl]) -> None:
        """check_decl of each declaration, or what it found the last time its text
        was checked, when every name it looked up is still what it was. A keystroke
        replays most of them: the replay is written out here, without a call, and
        the references of consecutive ones that moved alike are kept together (made
        into `Reference`s when first read)."""
        model = self.model
        symbols, uses, used = model.symbols, model.uses, self.used
        entry: Entry = ("names", model.time_unit)
        pending: list[tuple[str, Span]] = []  # reused references, moved by `moving`
        moving = 0
        for decl in decls:
            kept = findings(decl)
            known = None if kept is None else kept.get(entry)
            if known is not None:
                for name, kind, owner in known.lookups:
                    symbol = symbols.get(name)
                    if symbol is None or symbol.kind is not kind or symbol.owner != owner:
                        known = None
                        break
            if known is None:
                if pending:
                    uses.append(ReusedReferences(tuple(pending), moving, symbols))
                    pending = []
                if kept is None:
                    self.check_decl(decl)  # a declaration with a syntax error
                else:
                    self.check_and_remember(decl, kept, entry)
                continue
            delta = decl.span.start - known.start
            if known.references:
                if delta != moving and pending:
                    uses.append(ReusedReferences(tuple(pending), moving, symbols))
                    pending = []
                moving = delta
                pending += known.references
            used.update(known.used)
            if known.reads is not None:
                self.event_reads[id(decl)] = known.reads
                if delta:
                    self.reads_moved[id(decl)] = delta
        if pending:
            uses.append(ReusedReferences(tuple(pending), moving, symbols))

    def check_and_remember(self, decl: ast.Decl, kept: dict[Entry, object], entry: Entry) -> None:
        """check_decl, and what it found kept with the declaration's parse, when it
        found nothing wrong and every name it looked up was declared."""
        model = self.model
        found, references = len(self.diagnostics), len(model.uses)
        self.lookups = []
        try:
            self.check_decl(decl)
            lookups = self.lookups
        finally:
            self.lookups = None
        if len(self.diagnostics) > found or any(s is None for _, s in lookups):
            return  # a finding (or a name not found) is checked again each time
        reads = self.event_reads.get(id(decl))
        made = cast("list[Reference]", model.uses[references:])
        kept[entry] = Resolved(
            decl.span.start,
            tuple((name, s.kind, s.owner) for name, s in lookups if s is not None),
            tuple((r.name, r.span) for r in made),
            tuple(dict.fromkeys(r.name for r in made)),
            None if reads is None else tuple(reads),
        )

    def check_decl(self, decl: ast.Decl) -> None:
        match decl:
            case ast.DatabaseDecl():
                self.check_database(decl)
            case ast.TopicDecl():
                self.check_topic(decl)
            case ast.VarDecl():
                self.check_variable(decl)
            case ast.EventDecl():
                self.check_event(decl)
            case ast.AlertDecl():
                self.check_alert(decl)
            case ast.TransducerDecl():
                self.check_transducer(decl)
            case ast.PropertyDecl():
                self.check_property(decl)
            case ast.WhitelistDecl():
                self.check_whitelist(decl)
            case ast.NodeDecl():
                self.check_node(decl)
            case ast.IntrusionDecl():
                self.diagnostics += schemas.check_settings("intrusion", decl.settings, None, decl)
                self.check_actions(decl.actions)

    def check_database(self, decl: ast.DatabaseDecl) -> None:
        self.diagnostics += schemas.check_settings("database", decl.settings, decl.name, decl)
        retention_names: dict[str, ast.RetentionDecl] = {}
        for retention in decl.retentions:
            first = retention_names.setdefault(retention.name.name, retention)
            if first is not retention:
                self.once_only(
                    f"retention policy `{retention.name.name}`", retention.name, first.name
                )
            self.diagnostics += schemas.check_settings(
                "retention", retention.settings, retention.name, retention
            )
        for downsample in decl.downsamples:
            self.diagnostics += schemas.check_settings(
                "downsample", downsample.settings, downsample.name, downsample
            )
            self.check_downsample(downsample, retention_names)

    def check_downsample(
        self, downsample: ast.DownsampleDecl, retentions: dict[str, ast.RetentionDecl]
    ) -> None:
        for setting in downsample.settings:
            key, value = setting.key.name, setting.value
            if key in ("from", "into") and isinstance(value, ast.NameValue):
                name = value.ident.name
                if name not in retentions:
                    self.report(
                        error(
                            "RMV200",
                            f"undefined retention policy `{name}`",
                            value.span,
                            label="no `retention` of the database has this name",
                            help=did_you_mean(name, retentions)
                            or f"declare it: `retention {name} {{ duration = 30d }}`",
                        )
                    )
            if key == "measurements" and isinstance(value, ast.ListValue):
                for item in value.items:
                    if isinstance(item, ast.NameValue):
                        self.resolve(item.ident, MEASUREMENT_KINDS, "a variable or an event")

    def check_topic(self, decl: ast.TopicDecl) -> None:
        self.check_ros_name(decl.path, "topic", "RMV204")
        problem = message_type_problem([p.name for p in decl.msg_type.parts])
        if problem:
            self.report(
                error(
                    "RMV206",
                    f"invalid message type `{decl.msg_type.text}`",
                    decl.msg_type.span,
                    label=problem,
                    help="for example `carla_msgs/CarlaEgoVehicleStatus` or "
                    "`carla_msgs/msg/CarlaEgoVehicleStatus`",
                )
            )
        self.diagnostics += schemas.check_settings("qos", decl.qos, decl.name, decl)

    def check_variable(self, decl: ast.VarDecl) -> None:
        self.resolve(decl.source.topic, frozenset({Kind.TOPIC}), "a topic")
        has_wildcard = any(s.index == "*" for s in decl.source.segments)
        if decl.aggregate is None:
            return
        name = decl.aggregate.name
        if name == builtins.NUMBER:
            return  # a bool as 0 or 1; the types stage checks it is one bool
        if name not in ARRAY_AGGREGATES:
            self.report(
                error(
                    "RMV218",
                    f"unknown array aggregate `{name}`",
                    decl.aggregate.span,
                    label="expected " + ", ".join(ARRAY_AGGREGATES) + ", or `number`",
                    help=did_you_mean(name, (*ARRAY_AGGREGATES, "number")),
                )
            )
        elif not has_wildcard:
            self.report(
                error(
                    "RMV218",
                    f"`{name}` aggregates over an array, but the path has no `[*]`",
                    decl.source.span,
                    label="no `[*]` in this path",
                    help="mark the array to aggregate over, e.g. `objects[*].twist.linear.x`",
                )
            )

    def check_alert(self, decl: ast.AlertDecl) -> None:
        allowed = frozenset({Kind.VARIABLE, *EVENT_KINDS})
        seen: dict[str, ast.AlertLevel] = {}
        for level in decl.levels:
            first = seen.setdefault(level.severity.name, level)
            if first is not level:
                self.once_only(f"the `{level.severity.name}` level", level.severity, first.severity)
            self.check_expression(level.condition, allowed)
            if level.reset is not None:
                self.check_expression(level.reset, allowed)
        if not decl.levels:
            self.report(
                error(
                    "RMV209",
                    f"alert `{decl.name.name}` has no level",
                    decl.name.span,
                    label="an alert needs `info`, `warn` or `crit when ...`",
                    help="add e.g. `crit when EVelocityinKMH > 80 reset when EVelocityinKMH < 70`",
                )
            )
        self.diagnostics += schemas.check_settings("alert", decl.settings, decl.name, decl)
        self.check_actions(decl.actions)

    # ---- unused declarations ----

    def report_unused(self) -> None:
        if any(self.damaged_ranges.values()):
            return  # uses may be in the parts that did not parse
        symbols = self.model.symbols
        unused = symbols.keys() - self.used
        whitelisted = whitelisted_topics(self.model)
        for name in filter(unused.__contains__, symbols):  # in declaration order
            found = unused_warning(symbols[name], whitelisted)
            if found is not None:
                self.report(found)


def whitelisted_topics(model: Model) -> set[str]:
    """The topics the whitelists name: used though no variable reads them."""
    return {topic_of(model, w) for w in model.whitelists}


def unused_warning(symbol: Symbol, whitelisted: set[str]) -> Diagnostic | None:
    """RMV203 for a symbol no reference names, if its kind is one to report."""
    if symbol.kind is Kind.TOPIC:
        decl = symbol.decl
        assert isinstance(decl, ast.TopicDecl)
        if decl.path.value in whitelisted:
            return None
        why = "no variable reads this topic and no whitelist names it"
    elif symbol.kind is Kind.VARIABLE:
        why = "no event, alert or downsample reads this variable"
    elif symbol.kind in (Kind.VALUE_EVENT, Kind.BOOL_EVENT):
        why = "no event, alert, transition or property uses this event"
    else:
        return None
    return warning(
        "RMV203",
        f"{symbol.kind.value} `{symbol.name}` is never used",
        symbol.span,
        label=why,
        help="remove it, or use it",
    )


def check_names(
    specs: list[ast.Spec],
    sources: SourceMap,
    damaged: set[str] | None = None,
    damaged_ranges: dict[str, list[tuple[int, int]]] | None = None,
    incremental: bool = False,
) -> tuple[Model, list[Diagnostic]]:
    """The names stage; `incremental` reuses what earlier checks found in the
    declarations whose text has not changed (an editor's, rmvdsl.check.memo)."""
    checker = NameChecker(specs, sources, damaged or set(), damaged_ranges or {}, incremental)
    return checker.run()


def nothing_checked(model: Model) -> list[Diagnostic]:
    """A spec with no property, alert, whitelist, node rule or intrusion block checks
    nothing: a replay of it would pass anything (RMV226)."""
    if model.properties or model.alerts or model.whitelists or model.nodes:
        return []
    if model.intrusion is not None or not model.specs:
        return []
    return [warning(
        "RMV226",
        "the spec checks nothing: it declares no property, alert, whitelist or node rule",
        Span(model.specs[0].path, 0, 0), label="a replay or a monitor of it passes anything",
        help="add a `property NAME: FORMULA`, an `alert`, or a `whitelist` for a topic",
    )]  # fmt: skip
