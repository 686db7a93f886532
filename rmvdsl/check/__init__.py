"""The checker: a staged pipeline from files to one resolved model.

Stages, each with its own diagnostics: load (parse the file and its imports),
names (declare, resolve, check structure). Later stages (types, analyses) read the
model the earlier ones built.
"""

from __future__ import annotations

from dataclasses import dataclass

from rmvdsl.check.loader import UsageError, load
from rmvdsl.check.model import Model
from rmvdsl.check.names import check_names
from rmvdsl.diagnostics import Diagnostic, Severity, sort_key


@dataclass
class CheckResult:
    model: Model
    diagnostics: list[Diagnostic]

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.WARNING]


def check(path: str, text: str | None = None) -> CheckResult:
    """Check the spec at `path` (its text may be given, as the editor does).

    Raises UsageError only when the root file itself cannot be read."""
    loaded = load(path, text)
    model, name_diagnostics = check_names(
        loaded.specs, loaded.sources, loaded.damaged_names, loaded.damaged_ranges
    )
    diagnostics = sorted([*loaded.diagnostics, *name_diagnostics], key=sort_key)
    return CheckResult(model, diagnostics)


__all__ = ["CheckResult", "UsageError", "check"]
