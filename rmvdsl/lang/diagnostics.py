"""Diagnostics: what the checker tells the user.

Every diagnostic has a stable code from `rmvdsl.lang.codes`, a primary span, optional
secondary labels ("first declared here") and an optional `help` with a concrete fix.
"""

from __future__ import annotations

import dataclasses
import enum
import re
from collections.abc import Iterable
from dataclasses import dataclass, field

from rmvdsl.lang.codes import CODES
from rmvdsl.lang.source import Span


class Severity(enum.Enum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True)
class Label:
    span: Span
    message: str


@dataclass(frozen=True)
class Fix:
    """An edit that does what a diagnostic's help says: replace `span` with `text`
    (an empty span inserts). An editor offers it as a quick fix."""

    title: str
    span: Span
    text: str


@dataclass(frozen=True)
class Diagnostic:
    code: str
    severity: Severity
    message: str
    span: Span
    label: str = ""
    secondary: tuple[Label, ...] = ()
    help: str | None = None
    notes: tuple[str, ...] = field(default=())
    fixes: tuple[Fix, ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        if self.code not in CODES:
            raise ValueError(f"unregistered diagnostic code {self.code}")

    def with_notes(self, notes: Iterable[str]) -> Diagnostic:
        """The same diagnostic with lines of explanation after it (a witness trace)."""
        return dataclasses.replace(self, notes=tuple(notes))

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR


def error(
    code: str,
    message: str,
    span: Span,
    *,
    label: str = "",
    secondary: Iterable[Label] = (),
    help: str | None = None,
    fixes: Iterable[Fix] = (),
) -> Diagnostic:
    return Diagnostic(
        code, Severity.ERROR, message, span, label, tuple(secondary), help, fixes=tuple(fixes)
    )


def warning(
    code: str,
    message: str,
    span: Span,
    *,
    label: str = "",
    secondary: Iterable[Label] = (),
    help: str | None = None,
    fixes: Iterable[Fix] = (),
) -> Diagnostic:
    return Diagnostic(
        code, Severity.WARNING, message, span, label, tuple(secondary), help, fixes=tuple(fixes)
    )


def sort_key(diagnostic: Diagnostic) -> tuple[str, int, int, str]:
    span = diagnostic.span
    return (span.path, span.start, span.end, diagnostic.code)


_DID_YOU_MEAN = re.compile(r"did you mean `([^`]+)`\?")


def fixes_of(diagnostic: Diagnostic) -> tuple[Fix, ...]:
    """A diagnostic's fixes: its own, or the replacement its `did you mean` names
    (that help always proposes a word for the word the diagnostic points at)."""
    if diagnostic.fixes:
        return diagnostic.fixes
    found = _DID_YOU_MEAN.search(diagnostic.help or "")
    if found is None:
        return ()
    return (Fix(f"Replace with `{found.group(1)}`", diagnostic.span, found.group(1)),)


def did_you_mean(name: str, candidates: Iterable[str]) -> str | None:
    """A `help:` text naming the closest candidate, when one is close enough."""
    best = closest(name, candidates)
    return f"did you mean `{best}`?" if best else None


def closest(name: str, candidates: Iterable[str]) -> str | None:
    best: str | None = None
    best_distance = _cutoff(name)
    lowered = name.lower()
    for candidate in candidates:
        if candidate == name:
            continue
        if candidate.lower() == lowered:
            return candidate
        distance = _edit_distance(lowered, candidate.lower(), best_distance)
        if distance < best_distance:
            best, best_distance = candidate, distance
    return best


def may_sway(name: str, candidate: str) -> bool:
    """Whether `closest(name, ...)` could choose `candidate`, or choose otherwise
    for it being among the candidates: a candidate at the cutoff distance or
    farther is never chosen, and never lowers the distance to beat."""
    if candidate == name:
        return False  # skipped
    cutoff = _cutoff(name)
    return _edit_distance(name.lower(), candidate.lower(), cutoff) < cutoff


def _cutoff(name: str) -> int:
    """The edit distance at which a candidate is too far from `name` to be named."""
    return max(1, len(name) // 3) + 1


def _edit_distance(a: str, b: str, limit: int) -> int:
    """Damerau-Levenshtein (optimal string alignment), cut off at `limit`."""
    if abs(len(a) - len(b)) >= limit:
        return limit
    previous_previous: list[int] = []
    previous = list(range(len(b) + 1))
    for i, char_a in enumerate(a, 1):
        current = [i] + [0] * len(b)
        for j, char_b in enumerate(b, 1):
            cost = 0 if char_a == char_b else 1
            current[j] = min(previous[j] + 1, current[j - 1] + 1, previous[j - 1] + cost)
            if i > 1 and j > 1 and char_a == b[j - 2] and a[i - 2] == char_b:
                current[j] = min(current[j], previous_previous[j - 2] + 1)
        if min(current) >= limit:
            return limit
        previous_previous, previous = previous, current
    return previous[-1]
