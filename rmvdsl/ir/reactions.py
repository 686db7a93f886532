"""Lowering what a spec does about what it watches: transducers, properties, alerts,
their actions, whitelists and the intrusion block (a part of Lowering)."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from fractions import Fraction
from typing import Any

from rmvdsl.check.model import Model
from rmvdsl.check.types import TypeInfo
from rmvdsl.grammar import ast, printer
from rmvdsl.ir.conversions import LowerError, patterns, setting_value
from rmvdsl.lang import builtins
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.rmtld3 import facts
from rmvdsl.runtime.spec import pattern


class Reactions:
    """Lowering's transducers, properties, alerts, actions and intrusion rules."""

    model: Model
    types: TypeInfo

    # Lowering's, which this class is a part of.
    origin: Callable[[ast.Node], str]
    settings: Callable[[str, Iterable[ast.Setting]], dict[str, Any]]
    expr: Callable[[ast.Node], ir.Expr]

    def transducer(self, decl: ast.TransducerDecl) -> ir.Transducer:
        assert decl.initial is not None
        transitions = tuple(
            ir.Transition(
                t.source.name,
                t.dest.name,
                t.input.name,
                t.output.name if t.output else None,
                self.origin(t),
            )
            for t in decl.transitions
        )
        emits = tuple(dict.fromkeys(t.emit for t in transitions if t.emit))
        return ir.Transducer(
            name=decl.name.name,
            states=tuple(s.name for s in decl.states),
            initial=decl.initial.name,
            finals=tuple(f.name for f in decl.finals),
            complete=decl.complete,
            transitions=transitions,
            emits=emits,
            origin=self.origin(decl.name),
            doc=decl.doc,
        )

    # ---- properties ----

    def property(self, decl: ast.PropertyDecl) -> ir.Property:
        formula = decl.formula
        assert formula is not None, "a property without a formula passed the checker"
        compiled = self.types.formulas[decl.name.name]
        found = facts(compiled)
        values = self.settings("property", decl.settings)
        window = values["window"]
        horizon = Fraction(found.reach)  # the history kept: finite with no bound too
        return ir.Property(
            name=decl.name.name,
            text=printer.formula(formula),
            formula=compiled,
            propositions=tuple(found.propositions),
            horizon_future=Fraction(found.future),
            horizon_past=None if found.past == float("inf") else Fraction(found.past),
            rate=values["rate"],
            trigger=values["trigger"],
            window=horizon if window == builtins.DERIVED else window,
            lateness=values["lateness"],
            actions=self.actions(decl.actions),
            origin=self.origin(decl.name),
            doc=decl.doc,
        )

    # ---- alerts ----

    def alert(self, decl: ast.AlertDecl) -> ir.Alert:
        values = self.settings("alert", decl.settings)
        levels = tuple(
            ir.AlertLevel(
                level.severity.name,
                self.expr(level.condition),
                self.expr(level.reset) if level.reset is not None else None,
            )
            for level in decl.levels
        )
        reads = set()
        for level in decl.levels:
            reads |= ast.names_in(level.condition)
            if level.reset is not None:
                reads |= ast.names_in(level.reset)
        name = decl.name.name
        return ir.Alert(
            name=name,
            id=name if values["id"] == builtins.DERIVED else values["id"],
            message=decl.message.value if decl.message else name,
            details=values["details"],
            state_changes_only=values["state_changes_only"],
            no_recoveries=values["no_recoveries"],
            levels=levels,
            reads=tuple(sorted(reads)),
            actions=self.actions(decl.actions),
            origin=self.origin(decl.name),
            doc=decl.doc,
        )

    # ---- actions ----

    def actions(self, actions: Iterable[ast.Action]) -> tuple[ir.Action, ...]:
        return tuple(self.action(a) for a in actions)

    def action(self, node: ast.Action) -> ir.Action:
        signature = builtins.action(node.kind.name)
        positional = [a for a in node.args if a.key is None]
        given = dict(zip(signature.positional, positional, strict=False))
        given |= {a.key.name: a for a in node.args if a.key is not None}
        values = {
            name: setting_value(given[name].value) if name in given else parameter.default
            for name, parameter in signature.parameters.items()
        }
        match signature.name:
            case "log":
                return ir.Log(values["message"], values["level"])
            case "publish":
                return ir.Publish(values["topic"], values["message"])
            case "post":
                return ir.Post(values["url"], values["timeout"])
            case "exec":
                args = values["args"]
                return ir.Exec(values["command"], (args,) if isinstance(args, str) else args)
            case "tcp":
                return ir.Tcp(values["address"])
        raise LowerError(f"no lowering of action `{signature.name}`")

    # ---- intrusion detection ----

    def whitelist(self, decl: ast.WhitelistDecl) -> ir.Whitelist:
        if isinstance(decl.target, ast.Ident):
            topic_name: str | None = decl.target.name
            ros_name = self.model.topics[decl.target.name].path.value
        else:
            topic_name, ros_name = None, decl.target.value
        return ir.Whitelist(
            topic=pattern(ros_name),
            topic_name=topic_name,
            publishers=patterns(decl.publishers),
            subscribers=patterns(decl.subscribers),
            actions=self.actions(decl.actions),
            origin=self.origin(decl.target),
            doc=decl.doc,
        )

    def node_rule(self, decl: ast.NodeDecl) -> ir.NodeRule:
        return ir.NodeRule(
            node=pattern(decl.name.value),
            publishes=patterns(decl.publishes),
            subscribes=patterns(decl.subscribes),
            actions=self.actions(decl.actions),
            origin=self.origin(decl.name),
            doc=decl.doc,
        )

    def intrusion(self, decl: ast.IntrusionDecl | None) -> ir.Intrusion:
        values = self.settings("intrusion", decl.settings if decl else ())
        return ir.Intrusion(
            poll=values["poll"],
            default=values["default"],
            ignore_nodes=tuple(pattern(p) for p in values["ignore_nodes"]),
            infrastructure=values["infrastructure"],
            actions=self.actions(decl.actions) if decl else (),
            origin=self.origin(decl) if decl else "",
        )
