"""What the property analysis reports: what it found about each property (read by
the editor, which imports no solver, and by `--witnesses`), and its diagnostics, one
wording each: a property impossible on the system (RMV511, with a trace of pure
logic where it holds), one the solver could not decide (RMV516), one that others
imply (RMV515). A part of the analyzer."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rmvdsl.check.model import Model
from rmvdsl.grammar import ast
from rmvdsl.lang.diagnostics import Diagnostic, Label, Severity, error
from rmvdsl.logic.answers import Answer, Witness
from rmvdsl.logic.system import System
from rmvdsl.runtime.rmtld3 import facts as formula_facts
from rmvdsl.runtime.wording import counted


@dataclass
class PropertyFacts:
    """What the analyses found about one property, for the editor and `--witnesses`."""

    formula: Any
    satisfiable: Answer | None = None
    valid: Answer | None = None


@dataclass
class PropertyReport:
    facts: dict[str, PropertyFacts] = field(default_factory=dict)
    diagnostics: list[Diagnostic] = field(default_factory=list)


class PropertyFindings:
    """The analyzer's diagnostics (its state, which this class is a part of)."""

    model: Model
    system: System
    compiled: dict[str, Any]

    def impossible(
        self, decl: ast.PropertyDecl, pure: Witness | None, system: System
    ) -> Diagnostic:
        """RMV511, with a trace of pure logic where the property holds, if found."""
        names = set(formula_facts(self.compiled[decl.name.name]).propositions)
        machines = [m.name for m in system.relevant(names)]
        because = (
            "the transducer"
            + ("s " if len(machines) > 1 else " ")
            + ", ".join(f"`{m}`" for m in machines)
            if machines
            else "the events' conditions"
        )
        if machines:
            help = (
                "a transducer is in one state at a time, never in one its initial state "
                "cannot reach, and moves only along its transitions; check the states the "
                "property names"
            )
        else:
            events = sorted(n for n in names if n in system.never) or sorted(
                {n for pair in system.exclusive for n in pair if n in names}
            )
            help = (
                "no values of the variables make "
                + ", ".join(f"`{e}`" for e in events)
                + " hold as the property needs (a variable ranges over its ROS type); "
                "check the events' conditions"
            )
        found = error(
            "RMV511",
            f"property `{decl.name.name}` can never hold on this system: it needs traces "
            f"that {because} cannot make",
            decl.name.span,
            label="satisfiable in pure logic, impossible here" if pure else "impossible here",
            help=help,
        )
        if pure is None:
            return found
        return found.with_notes(("without the spec's constraints it holds on:", *pure.timeline()))

    def undecided(self, decl: ast.PropertyDecl, question: str, answer: Answer) -> Diagnostic:
        return Diagnostic(
            "RMV516",
            Severity.NOTE,
            f"could not decide whether property `{decl.name.name}` {question}: {answer.note}",
            decl.name.span,
            label="undecided",
            help="raise the limit: `rmv check --timeout SECONDS`, or `solver_timeout` "
            "and `solver_effort` in rmv.toml",
        )

    def redundancy_skipped(self, group: list[str], limit: int) -> Diagnostic:
        shown = ", ".join(f"`{n}`" for n in group[:3])
        more = len(group) - 3
        return Diagnostic(
            "RMV517",
            Severity.NOTE,
            f"redundancy not checked for {counted(len(group), 'property', 'properties')} "
            f"that share propositions ({shown}{f' and {more} more' if more > 0 else ''}): "
            f"over {limit}",
            self.model.properties[group[0]].name.span,
            label="redundancy not checked",
            help="split the group to have it checked (`rmv explain RMV517`)",
        )

    def implied(self, name: str, implied_by: list[str]) -> Diagnostic:
        return Diagnostic(
            "RMV515",
            Severity.NOTE,
            f"property `{name}` is implied by "
            + ", ".join(f"`{n}`" for n in implied_by)
            + ": its monitor fires only when theirs do",
            self.model.properties[name].name.span,
            label="redundant",
            secondary=tuple(
                Label(self.model.properties[n].name.span, "implies it") for n in implied_by
            ),
            help="keep it if a separate alert is wanted; otherwise drop it",
        )
