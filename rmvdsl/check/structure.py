"""Transducers, properties and whitelists (names stage): each one's structure and
the names it resolves (a part of NameChecker)."""

from __future__ import annotations

from collections.abc import Callable, Iterable

import rmvdsl.check.settings as schemas
from rmvdsl.check.model import BOOLEAN_KINDS, PROPOSITION_KINDS, Kind, Model, Reference, Symbol
from rmvdsl.check.whitelists import topic_of
from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.lang.diagnostics import Diagnostic, Fix, did_you_mean, error
from rmvdsl.lang.source import Span
from rmvdsl.logic.validate import check_formula


class StructureChecks:
    """The names stage's checks of transducers, properties and whitelists."""

    model: Model
    diagnostics: list[Diagnostic]
    lookups: list[tuple[str, Symbol | None]] | None
    used: set[str]  # the names of used symbols

    # NameChecker's and ActionChecks', which this class is a part of beside them.
    report: Callable[[Diagnostic], None]
    resolve: Callable[[ast.Ident, frozenset[Kind], str], Symbol | None]
    once_only: Callable[..., None]
    check_ros_name: Callable[..., None]
    check_actions: Callable[[Iterable[ast.Action]], None]

    def check_transducer(self, decl: ast.TransducerDecl) -> None:
        own = {s.name for s in decl.states}
        if not decl.states:
            self.missing(decl, "states", "states Idle, Active")
        if decl.initial is None:
            self.missing(
                decl, "initial", f"initial {decl.states[0].name if decl.states else 'Idle'}"
            )
        else:
            self.check_state(decl, decl.initial, own)
        for final in decl.finals:
            self.check_state(decl, final, own)
        for transition in decl.transitions:
            self.check_state(decl, transition.source, own)
            self.check_state(decl, transition.dest, own)
            self.resolve(transition.input, BOOLEAN_KINDS, "a boolean event")

    def missing(self, decl: ast.TransducerDecl, what: str, example: str) -> None:
        self.report(
            error(
                "RMV209",
                f"transducer `{decl.name.name}` has no `{what}`",
                decl.name.span,
                label=f"`{what}` is required",
                help=f"add `{example}` to the transducer",
            )
        )

    def check_state(self, decl: ast.TransducerDecl, ident: ast.Ident, own: set[str]) -> None:
        if ident.name in own:
            symbol = self.model.symbols.get(ident.name)
            if self.lookups is not None:
                self.lookups.append((ident.name, symbol))
            if symbol is not None and symbol.owner == decl.name.name:
                self.model.uses.append(Reference(ident.name, ident.span, symbol))
                self.used.add(symbol.name)
            return
        other = self.model.state_owner(ident.name)
        if other is not None:
            message = (
                f"`{ident.name}` is a state of transducer `{other}`, not of `{decl.name.name}`"
            )
        else:
            message = f"`{ident.name}` is not a state of transducer `{decl.name.name}`"
        self.report(
            error(
                "RMV210",
                message,
                ident.span,
                label="not in this transducer's `states`",
                help=did_you_mean(ident.name, own) or f"add `{ident.name}` to `states`",
                fixes=self.state_added(decl, ident.name) if other is None else (),
            )
        )

    @staticmethod
    def state_added(decl: ast.TransducerDecl, name: str) -> tuple[Fix, ...]:
        """The edit adding a state after the last of `states` (when the name is no
        near miss of one: then `did you mean` is the fix)."""
        own = [s.name for s in decl.states]
        if not decl.states or did_you_mean(name, own):
            return ()
        last = decl.states[-1].span
        title = f"Add `{name}` to the states of `{decl.name.name}`"
        return (Fix(title, Span(last.path, last.end, last.end), f", {name}"),)

    def check_property(self, decl: ast.PropertyDecl) -> None:
        formula = decl.formula
        if formula is not None:
            self.check_formula(formula)
        self.diagnostics += schemas.check_settings("property", decl.settings, decl.name, decl)
        for setting in decl.settings:
            value = setting.value
            is_trigger = setting.key.name == "trigger" and isinstance(value, ast.NameValue)
            if is_trigger and value.ident.name != "always":  # type: ignore[union-attr]
                self.resolve(value.ident, PROPOSITION_KINDS, "a state or a boolean event")  # type: ignore[union-attr]
        self.check_actions(decl.actions)

    def check_formula(self, formula: fm.Formula) -> None:
        for node in fm.walk(formula):
            if isinstance(node, fm.Prop):
                ident = ast.Ident(node.name, node.span)
                self.resolve(ident, PROPOSITION_KINDS, "a state or a boolean event")
        source = self.model.sources.get(formula.span.path)
        text = source.text if source is not None else None
        self.diagnostics += check_formula(formula, self.model.time_unit, text)

    def check_whitelist(self, decl: ast.WhitelistDecl) -> None:
        if isinstance(decl.target, ast.Ident):
            self.resolve(decl.target, frozenset({Kind.TOPIC}), "a topic")
        else:
            self.check_ros_name(decl.target, "topic", "RMV204", patterns=True)
        for pattern in (*(decl.publishers or ()), *(decl.subscribers or ())):
            self.check_ros_name(pattern, "node", "RMV205", patterns=True)
        if decl.publishers is None and decl.subscribers is None:
            self.report(
                error(
                    "RMV209",
                    "whitelist names neither publishers nor subscribers",
                    decl.target.span,
                    label="empty whitelist",
                    help='add e.g. `publishers: "/carla_ros_bridge"` (or `publishers: none`)',
                )
            )
        self.check_actions(decl.actions)

    def check_node(self, decl: ast.NodeDecl) -> None:
        self.check_ros_name(decl.name, "node", "RMV205", patterns=True)
        for pattern in (*(decl.publishes or ()), *(decl.subscribes or ())):
            self.check_ros_name(pattern, "topic", "RMV204", patterns=True)
        self.check_actions(decl.actions)

    def check_whitelist_duplicates(self) -> None:
        seen: dict[str, ast.WhitelistDecl] = {}
        for decl in self.model.whitelists:
            key = self.whitelist_topic(decl)
            first = seen.setdefault(key, decl)
            if first is not decl:
                self.once_only(f"the whitelist of `{key}`", decl.target, first.target)
        nodes: dict[str, ast.NodeDecl] = {}
        for node in self.model.nodes:
            first_node = nodes.setdefault(node.name.value, node)
            if first_node is not node:
                self.once_only(
                    f"the whitelist of node `{node.name.value}`", node.name, first_node.name
                )

    def whitelist_topic(self, decl: ast.WhitelistDecl) -> str:
        return topic_of(self.model, decl)
