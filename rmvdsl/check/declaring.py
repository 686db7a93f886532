"""Declaring (names stage, first pass): every symbol into the one namespace, the
blocks a spec has once, and the events transducers emit (a part of NameChecker)."""

from __future__ import annotations

from typing import cast

from rmvdsl.check.model import Kind, Model, Symbol
from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.lang.diagnostics import Diagnostic, Label, did_you_mean, error

TIME_UNIT_NAMES = tuple(fm.TIME_UNITS)  # ns, us, ms, s, m, h, d, w
_ONE_PER_SPEC = "a spec has one (its imports included): remove or merge the second"
# Declarations of one named symbol each: its kind (an event's, if boolean) and the
# model's map of them. Looked up by type: a keystroke declares every declaration.
_SIMPLE: dict[type, tuple[Kind, str]] = {
    ast.TopicDecl: (Kind.TOPIC, "topics"),
    ast.VarDecl: (Kind.VARIABLE, "variables"),
    ast.EventDecl: (Kind.BOOL_EVENT, "events"),
    ast.AlertDecl: (Kind.ALERT, "alerts"),
    ast.PropertyDecl: (Kind.PROPERTY, "properties"),
}


class Declarations:
    """The first pass of the names stage: declare before anything is resolved."""

    model: Model
    diagnostics: list[Diagnostic]
    time_unit_decl: ast.TimeUnitDecl | None
    reserved: frozenset[str]  # rmvdsl.grammar.grammars.reserved_names, read once per check

    def report(self, diagnostic: Diagnostic) -> None:
        self.diagnostics.append(diagnostic)

    def declare_all(self, decls: list[ast.Decl]) -> None:
        """Declare each declaration: the most common ones (a name of one kind) here,
        those neither taken nor reserved without a call (a keystroke declares them
        all), the others by `declare_other`."""
        model = self.model
        symbols, reserved = model.symbols, self.reserved
        simple = {cls: (kind, getattr(model, group)) for cls, (kind, group) in _SIMPLE.items()}
        for decl in decls:
            found = simple.get(type(decl))
            if found is None:
                self.declare_other(decl)
                continue
            kind, group = found
            if kind is Kind.BOOL_EVENT and not cast("ast.EventDecl", decl).boolean:
                kind = Kind.VALUE_EVENT
            ident = decl.name  # type: ignore[attr-defined]
            name = ident.name
            if name in symbols or name in reserved:
                if self.add(ident, kind, decl):
                    group.setdefault(name, decl)
                continue
            symbols[name] = Symbol(name, kind, ident.span, decl)
            group[name] = decl  # a name not declared is in no group

    def declare_other(self, decl: ast.Decl) -> None:
        """A declaration that is not a name of one kind (`_SIMPLE`)."""
        model = self.model
        match decl:
            case ast.SystemDecl():
                if model.system is not None:
                    self.once_only("`system`", decl.name, model.system.name, _ONE_PER_SPEC)
                else:
                    model.system = decl
            case ast.TimeUnitDecl():
                self.declare_time_unit(decl)
            case ast.RosDecl():
                if model.ros is not None:
                    self.once_only("`ros`", decl.distro, model.ros.distro, _ONE_PER_SPEC)
                else:
                    model.ros = decl
            case ast.MessagesDecl():
                model.messages.append(decl)
            case ast.DatabaseDecl():
                if model.database is not None:
                    self.once_only(
                        "`database`",
                        decl.name or decl,
                        model.database.name or model.database,
                        _ONE_PER_SPEC,
                    )
                else:
                    model.database = decl
            case ast.TransducerDecl():
                self.declare_transducer(decl)
            case ast.WhitelistDecl():
                model.whitelists.append(decl)
            case ast.NodeDecl():
                model.nodes.append(decl)
            case ast.IntrusionDecl():
                if model.intrusion is not None:
                    self.once_only("the `intrusion` block", decl, model.intrusion, _ONE_PER_SPEC)
                else:
                    model.intrusion = decl

    def declare_time_unit(self, decl: ast.TimeUnitDecl) -> None:
        unit = decl.unit.name
        if self.time_unit_decl is not None:
            self.once_only("`time unit`", decl.unit, self.time_unit_decl.unit, _ONE_PER_SPEC)
            return
        self.time_unit_decl = decl
        if unit not in TIME_UNIT_NAMES:
            self.report(
                error(
                    "RMV208",
                    f"unknown time unit `{unit}`",
                    decl.unit.span,
                    label="expected " + ", ".join(TIME_UNIT_NAMES),
                    help=did_you_mean(unit, TIME_UNIT_NAMES),
                )
            )
            return
        self.model.time_unit = unit

    def declare_transducer(self, decl: ast.TransducerDecl) -> None:
        if self.add(decl.name, Kind.TRANSDUCER, decl):
            self.model.transducers.setdefault(decl.name.name, decl)
        for state in decl.states:
            self.add(state, Kind.STATE, decl, owner=decl.name.name)
        for transition in decl.transitions:
            if transition.output is not None:
                self.declare_emitted(decl, transition)

    def declare_emitted(self, decl: ast.TransducerDecl, transition: ast.Transition) -> None:
        output = transition.output
        assert output is not None
        existing = self.model.symbols.get(output.name)
        if existing is None:
            self.add(output, Kind.EMITTED_EVENT, transition, owner=decl.name.name)
        elif existing.kind is not Kind.EMITTED_EVENT:
            self.report(
                error(
                    "RMV201",
                    f"`{output.name}` is emitted here but already declared as "
                    f"{existing.kind.described()}",
                    output.span,
                    label="emitted by this transition",
                    secondary=[
                        Label(existing.span, f"declared as {existing.kind.described()} here")
                    ],
                    help="an emitted event is declared by `emit`: give it a name of its own",
                )
            )
            return
        self.model.emitted.setdefault(output.name, []).append(transition)

    def add(self, ident: ast.Ident, kind: Kind, decl: ast.Node, owner: str | None = None) -> bool:
        if ident.name in self.reserved:
            self.report(
                error(
                    "RMV221",
                    f"`{ident.name}` is a keyword: {kind.described()} named so could never be "
                    "referred to",
                    ident.span,
                    label="a keyword of expressions and formulas",
                    help=f"rename it, e.g. `{ident.name.capitalize()}` or `{ident.name}_`",
                )
            )
        existing = self.model.symbols.get(ident.name)
        if existing is not None:
            self.report(
                error(
                    "RMV201",
                    f"`{ident.name}` is declared more than once",
                    ident.span,
                    label=f"declared again here as {kind.described()}",
                    secondary=[
                        Label(existing.span, f"first declared here as {existing.kind.described()}")
                    ],
                    help="topics, variables, events, alerts, transducers, states and properties "
                    "share one namespace: rename one of them",
                )
            )
            return False
        self.model.symbols[ident.name] = Symbol(ident.name, kind, ident.span, decl, owner)
        return True

    def once_only(
        self, what: str, again: ast.Node, first: ast.Node, help: str = "keep only one"
    ) -> None:
        self.report(
            error(
                "RMV214",
                f"{what} is given more than once",
                again.span,
                label="given again here",
                secondary=[Label(first.span, "first given here")],
                help=help,
            )
        )
