"""Types of alerts and properties (stage 3, a part of TypeChecker): their
conditions, windows, duration terms and units, and each property's horizons."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from fractions import Fraction
from typing import Any

from rmvdsl.check.exprtypes import ExpressionTypes
from rmvdsl.check.typeinfo import Horizon
from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.lang.diagnostics import Label, error
from rmvdsl.lang.source import Span
from rmvdsl.logic.compile import CompileError, compile_formula
from rmvdsl.runtime.rmtld3 import facts


class PropertyTypes(ExpressionTypes):
    """Alerts' conditions, properties' formulas, windows and duration units."""

    # TypeChecker's: a declaration typed once, remembered for incremental checks.
    remembered: Callable[[Any, Callable[[Any], Any]], Any]

    def check_alert(self, alert: ast.AlertDecl) -> None:
        self.remembered(alert, self.type_alert)

    def type_alert(self, alert: ast.AlertDecl) -> None:
        for level in alert.levels:
            self.condition(level.condition, f"the `{level.severity.name}` condition")
            if level.reset is None:
                continue
            self.condition(level.reset, f"the `{level.severity.name}` reset condition")
            measured = ast.names_in(level.condition)
            reset = ast.names_in(level.reset)
            foreign = sorted(reset - measured)
            if foreign or not reset:
                self.report(
                    error(
                        "RMV317",
                        f"the reset of `{level.severity.name}` watches "
                        + (", ".join(f"`{n}`" for n in foreign) if foreign else "no measurement")
                        + ", not what the condition watches "
                        + f"({', '.join(sorted(measured)) or 'nothing'})",
                        level.reset.span,
                        label="a different measurement",
                        secondary=[Label(level.condition.span, "the condition")],
                        help="an alert resets on the measurement that raised it",
                    )
                )

    def check_property(self, prop: ast.PropertyDecl) -> None:
        found = self.remembered(prop, self.type_property)
        if found is not None:
            self.info.formulas[prop.name.name], self.info.horizons[prop.name.name] = found

    def type_property(self, prop: ast.PropertyDecl) -> Any:
        """The compiled formula and its horizon (None when it has none, or when it
        does not compile)."""
        formula = prop.formula
        if formula is None:
            return None
        for node in fm.walk(formula):
            if isinstance(node, fm.Compare):
                self.compare_terms(node)
        found = self.horizon(formula)
        if found is None:
            return None
        self.check_window(prop, formula, found[1])
        return found

    def check_window(self, prop: ast.PropertyDecl, formula: fm.Formula, horizon: Horizon) -> None:
        window = next((s for s in prop.settings if s.key.name == "window"), None)
        if window is None or not isinstance(window.value, ast.TimeLit):
            return
        seconds = window.value.time.seconds()
        if seconds is not None and seconds < horizon.total:
            self.report(
                error(
                    "RMV318",
                    f"the window of `{prop.name.name}` ({window.value.time.text}) is shorter than "
                    f"its horizon ({seconds_text(horizon.total)})",
                    window.value.span,
                    label=f"the formula looks {seconds_text(horizon.future)} ahead"
                    + (f" and {seconds_text(horizon.past)} back" if horizon.past else ""),
                    secondary=[Label(formula.span, "this formula")],
                    help=f"set `window = {seconds_text(horizon.total)}` or more",
                )
            )

    def term_unit(self, term: fm.Term) -> int | None:
        """The time exponent of a term: 1 for a duration, 0 for a plain number,
        None for a bare number that the spec's time unit makes a duration."""
        match term:
            case fm.Duration():
                return 1
            case fm.Number():
                if term.time is not None:
                    return 1
                return None if self.model.time_unit is not None else 0
            case fm.Arith():
                left, right = self.term_unit(term.left), self.term_unit(term.right)
                if term.op == "*":
                    return (
                        (left or 0) + (right or 0) if None not in (left, right) else (left or right)
                    )
                return left if left is not None else right
        return 0

    def compare_terms(self, node: fm.Compare) -> None:
        pairs: list[tuple[fm.Term, fm.Term]] = [(node.left, node.right)]
        for term in (node.left, node.right):
            pairs += [(t.left, t.right) for t in _sums(term)]
        for left, right in pairs:
            units = (self.term_unit(left), self.term_unit(right))
            if None in units or units[0] == units[1]:
                continue
            self.report(
                error(
                    "RMV315",
                    "compares a duration with a plain number"
                    if 0 in units and 1 in units
                    else "compares terms of different time units",
                    Span(left.span.path, left.span.start, right.span.end),
                    label="durations are times",
                    secondary=[
                        Label(left.span, _unit_word(units[0])),
                        Label(right.span, _unit_word(units[1])),
                    ],
                    help="give the number a unit (`4s`), or declare `time unit s` for the spec",
                )
            )
            return

    def horizon(self, formula: fm.Formula) -> tuple[Any, Horizon] | None:
        """The compiled formula and how far it looks ahead and back: the runtime's
        own traversal of it (rmvdsl.runtime.rmtld3.facts), kept for later stages."""
        try:
            compiled = compile_formula(formula, Fraction(1), self.model.time_unit)
        except CompileError:
            return None  # a bound without a unit or a bad term: the names stage said so
        found = facts(compiled)
        past = None if found.past == float("inf") else Fraction(found.past)
        return compiled, Horizon(Fraction(found.future), past, Fraction(found.reach))


def _sums(term: fm.Term) -> Iterator[fm.Arith]:
    """The `+` and `-` of a term, not looking inside duration bodies."""
    stack = [term]
    while stack:
        node = stack.pop()
        if isinstance(node, fm.Arith):
            if node.op in "+-":
                yield node
            stack += [node.right, node.left]


def _unit_word(unit: int | None) -> str:
    return {0: "a plain number", 1: "a duration"}.get(unit or 0, f"time^{unit}")


def seconds_text(value: Fraction) -> str:
    from rmvdsl.lang.numbers import decimal

    return f"{decimal(value)}s"
