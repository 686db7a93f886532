"""The checker: a staged pipeline from files to one resolved model.

Stages, each with its own diagnostics: load (parse the file and its imports),
names (declare, resolve, check structure), types (message definitions, field
paths, expressions, units, horizons), analyses (transducers, with networkx and
z3; then properties, in dense time with z3, on the declarations without errors).
Each stage reads what the earlier ones built; the result is one model that every
later analysis and target reads.
"""

from __future__ import annotations

import bisect
import contextlib
import gc
import os
import re
import sys
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

from rmvdsl.check.lateness import lateness_warnings
from rmvdsl.check.loader import Reader, load
from rmvdsl.check.model import Model
from rmvdsl.check.msgtypes import DISTROS
from rmvdsl.check.names import check_names, nothing_checked
from rmvdsl.check.types import TypeConfig, TypeInfo, check_types
from rmvdsl.lang.diagnostics import Diagnostic, Severity, did_you_mean, error, sort_key, warning
from rmvdsl.lang.errors import UsageError
from rmvdsl.lang.files import read_text
from rmvdsl.lang.source import SourceFile, Span
from rmvdsl.util.cache import flush
from rmvdsl.util.deep import deep

if TYPE_CHECKING:
    from rmvdsl.check.analysis import AnalysisResult
    from rmvdsl.check.properties import PropertyReport
    from rmvdsl.logic.sat import Limits

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

CONFIG_FILE = "rmv.toml"
# z3's Python objects live in one context that is not safe to share between threads
# (six threads checking at once crashed the process): the solver stages take turns.
# Parsing, names and types run in parallel.
SOLVER_LOCK = threading.RLock()
# Name diagnostics that a syntax error in the same declaration can cause.
CONSEQUENTIAL = frozenset({"RMV200", "RMV209", "RMV210", "RMV213"})


@dataclass
class CheckResult:
    model: Model
    diagnostics: list[Diagnostic]
    types: TypeInfo | None = None
    analysis: AnalysisResult | None = None
    properties: PropertyReport | None = None

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.WARNING]


def check(
    path: str,
    text: str | None = None,
    ros: str | None = None,
    messages: tuple[str, ...] = (),
    use_environment: bool = True,
    solver_timeout: float | None = None,
    read: Reader = read_text,
    solver: bool = True,
    solver_jobs: int | None = None,
    incremental: bool = False,
) -> CheckResult:
    """Check the spec at `path` (its text may be given, as the editor does).

    `read` reads the files (rmvdsl.editor.workspace reads an editor's open documents
    first). Without `solver`, only the fast stages run (loading, names, types),
    so an editor shows their diagnostics while the solver stages still run.

    `ros` and `messages` come from the command line and win over the spec's own
    `ros` and `messages` declarations, which win over an rmv.toml beside the spec.
    `solver_timeout` (seconds per solver call on the properties) wins over the
    `solver_timeout` of rmv.toml (docs/verification.md); `solver_jobs` (processes
    answering independent solver questions at once) over its `solver_jobs`.
    `incremental` (an editor's) reuses what earlier checks found in declarations
    whose text has not changed (rmvdsl.check.memo): the same answer, sooner.
    Raises UsageError only when the root file itself cannot be read. Runs on a deep
    stack (rmvdsl.util.deep): a generated spec's formulas can nest 100,000 levels."""
    options = (ros, messages, use_environment, solver_timeout, read, solver, solver_jobs)
    try:
        with fewer_full_collections():
            return deep(_check, path, text, *options, incremental)
    finally:
        flush()  # the answers on disk, for the next process to read


FULL_COLLECTION_THRESHOLD = 1000  # Python's default: 10
_collections_lock = threading.Lock()
_collections_users = 0
_collections_saved: tuple[int, int, int] = (700, 10, 10)


@contextlib.contextmanager
def fewer_full_collections() -> Iterator[None]:
    """Python's full garbage collections (every 10 of the middle generation's)
    walk every live object: a check builds millions, so their cost grew faster than
    the spec (the 10x spec's load 13x, its names 14x the 1x spec's). While any
    check runs, full collections come 100 times less often; the threshold is given
    back when the last one ends."""
    global _collections_users, _collections_saved
    with _collections_lock:
        if _collections_users == 0:
            _collections_saved = gc.get_threshold()
            first, second, third = _collections_saved
            gc.set_threshold(first, second, max(third, FULL_COLLECTION_THRESHOLD))
        _collections_users += 1
    try:
        yield
    finally:
        with _collections_lock:
            _collections_users -= 1
            if _collections_users == 0:
                gc.set_threshold(*_collections_saved)


def _check(
    path: str,
    text: str | None,
    ros: str | None,
    messages: tuple[str, ...],
    use_environment: bool,
    solver_timeout: float | None,
    read: Reader,
    solver: bool,
    solver_jobs: int | None,
    incremental: bool,
) -> CheckResult:
    loaded = load(path, text, read)
    model, name_diagnostics = check_names(
        loaded.specs, loaded.sources, loaded.damaged_names, loaded.damaged_ranges, incremental
    )
    # Paths stay as the user wrote them (relative stays relative) in diagnostics.
    folder = os.path.dirname(path) or "."
    file_config, config_diagnostics = read_config(folder, model)
    limits = file_config.limits(solver_timeout, solver_jobs)
    config = TypeConfig(
        ros=ros or (None if model.ros else file_config.ros),
        messages=(*messages, *file_config.messages),
        use_environment=use_environment,
    )
    types, type_diagnostics = check_types(model, config, folder, incremental)
    type_diagnostics = [*type_diagnostics, *lateness_warnings(model)]
    if not solver:
        fast = _quieted(
            model, [*loaded.diagnostics, *config_diagnostics], name_diagnostics, type_diagnostics
        )
        return CheckResult(model, sorted(_said_if_empty(model, fast), key=sort_key), types)
    # networkx and z3 load only when a check runs, not for `rmv --version` or `fmt`.
    from rmvdsl.check.analysis import analyze

    found = [*loaded.diagnostics, *config_diagnostics, *name_diagnostics, *type_diagnostics]
    with SOLVER_LOCK:
        analysis, analysis_diagnostics = analyze(model, types, broken_declarations(model, found))
    earlier = _quieted(
        model,
        [*loaded.diagnostics, *config_diagnostics],
        name_diagnostics,
        [*type_diagnostics, *analysis_diagnostics],
    )
    from rmvdsl.check.properties import analyze_properties

    skip = broken_declarations(model, earlier)
    with SOLVER_LOCK:
        report = analyze_properties(model, types, analysis, skip, limits)
    diagnostics = sorted(_said_if_empty(model, [*earlier, *report.diagnostics]), key=sort_key)
    return CheckResult(model, diagnostics, types, analysis, report)


def _said_if_empty(model: Model, diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    """RMV226 for a spec that checks nothing, once it has no error to fix first."""
    if any(d.severity is Severity.ERROR for d in diagnostics):
        return diagnostics
    return [*diagnostics, *nothing_checked(model)]


def _quieted(
    model: Model, kept: list[Diagnostic], names: list[Diagnostic], later: list[Diagnostic]
) -> list[Diagnostic]:
    """Inside a declaration with syntax errors parts may be missing: what follows
    from a missing part is not reported (the consequential name findings, and
    everything the type and solver stages found there), the syntax error is."""
    names = [d for d in names if not (d.code in CONSEQUENTIAL and model.in_damaged(d.span))]
    return [*kept, *names, *[d for d in later if not model.in_damaged(d.span)]]


def broken_declarations(model: Model, diagnostics: list[Diagnostic]) -> set[str]:
    """The declarations with an error inside (or a syntax error), and every one that
    reads one of them, directly or through others: no analysis claims anything
    about them (a name that does not resolve is not a free value to solve for)."""
    errors: dict[str, list[int]] = {}
    for d in diagnostics:
        if d.severity is Severity.ERROR:
            errors.setdefault(d.span.path, []).append(d.span.start)
    for starts in errors.values():
        starts.sort()
    broken = set()
    for name, span in model.declaration_spans().items():
        starts = errors.get(span.path, [])
        first = bisect.bisect_left(starts, span.start)  # the first error at or after it
        if model.in_damaged(span) or (first < len(starts) and starts[first] < span.end):
            broken.add(name)
    readers: dict[str, set[str]] = {}
    for name, names in model.reads().items():
        for read in names:
            readers.setdefault(read, set()).add(name)
    pending = list(broken)
    while pending:  # each declaration once: a chain of 10,000 events is one walk
        for reader in readers.get(pending.pop(), ()):
            if reader not in broken:
                broken.add(reader)
                pending.append(reader)
    return broken


@dataclass(frozen=True)
class FileConfig:
    """What an rmv.toml beside the spec says."""

    ros: str | None = None
    messages: tuple[str, ...] = ()
    solver_timeout: float | None = None  # seconds per solver call
    solver_effort: int | None = None  # z3's resource limit: the same on every machine
    solver_jobs: int | None = None  # processes answering solver questions at once

    def limits(self, timeout: float | None, jobs: int | None = None) -> Limits:
        from rmvdsl.logic.sat import Limits

        return Limits(
            timeout=timeout or self.solver_timeout or Limits.timeout,
            effort=self.solver_effort,
            jobs=jobs or self.solver_jobs,
        )


def read_config(folder: str, model: Model) -> tuple[FileConfig, list[Diagnostic]]:
    """The settings of an rmv.toml in the spec's folder, if any."""
    path = os.path.join(folder, CONFIG_FILE)
    if not os.path.isfile(path):
        return FileConfig(), []
    try:
        with open(path, encoding="utf-8") as handle:
            text = handle.read()
    except (OSError, UnicodeDecodeError) as exc:
        source = model.sources.add(SourceFile(path, ""))
        return FileConfig(), [
            error("RMV307", f"cannot read {CONFIG_FILE}: {exc}", source.span(0, 0))
        ]
    source = model.sources.add(SourceFile(path, text))
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        match = re.search(r"line (\d+), column (\d+)", str(exc))
        line, column = (int(match.group(1)), int(match.group(2))) if match else (1, 1)
        start = source.offset(line, column)
        return FileConfig(), [
            error(
                "RMV307",
                f"{CONFIG_FILE} is not valid TOML: {str(exc).split(' (at')[0]}",
                source.span(start, start + 1),
                label="here",
            )
        ]
    return _config_values(data.get("rmv", data), source, folder)


# Each key of rmv.toml: whether a value is right, and what it must be.
_CONFIG_KEYS: dict[str, tuple[Callable[[object], bool], str]] = {
    "ros": (lambda v: isinstance(v, str) and v in DISTROS, 'a ROS distribution (e.g. "humble")'),
    "messages": (
        lambda v: (
            isinstance(v, str) or (isinstance(v, list) and all(isinstance(f, str) for f in v))
        ),
        "a folder or a list of folders",
    ),
    "solver_timeout": (
        lambda v: not isinstance(v, bool) and isinstance(v, int | float) and 0 < v <= 3600,
        "a number of seconds in (0, 3600]",
    ),
    "solver_effort": (
        lambda v: not isinstance(v, bool) and isinstance(v, int) and v >= 1,
        "a positive whole number",
    ),
    "solver_jobs": (
        lambda v: not isinstance(v, bool) and isinstance(v, int) and 1 <= v <= 1024,
        "a whole number of processes in [1, 1024]",
    ),
}


def _config_values(
    section: dict[str, object], source: SourceFile, folder: str
) -> tuple[FileConfig, list[Diagnostic]]:
    problems: list[Diagnostic] = []
    good: dict[str, object] = {}
    for key, value in section.items():
        where = _key_span(source, key)
        if key == "rmv" and isinstance(value, dict):
            continue
        if key not in _CONFIG_KEYS:
            problems.append(
                warning(
                    "RMV308",
                    f"unknown key `{key}` in {CONFIG_FILE}: it is ignored",
                    where,
                    label="not a setting rmv reads",
                    help=did_you_mean(key, list(_CONFIG_KEYS))
                    or "the keys are " + ", ".join(f"`{k}`" for k in _CONFIG_KEYS),
                )
            )
            continue
        accepts, wanted = _CONFIG_KEYS[key]
        if accepts(value):
            good[key] = value
            continue
        hint = did_you_mean(str(value), DISTROS) if key == "ros" else None
        problems.append(
            error(
                "RMV307",
                f"`{key}` in {CONFIG_FILE} must be {wanted}, not {_toml_text(value)}",
                where,
                label="invalid value",
                help=hint or (("known: " + ", ".join(DISTROS)) if key == "ros" else None),
            )
        )
    folders = good.get("messages", [])
    folders = [folders] if isinstance(folders, str) else folders
    return (
        FileConfig(
            cast("str | None", good.get("ros")),
            tuple(os.path.join(folder, f) for f in cast("list[str]", folders)),
            cast("float | None", good.get("solver_timeout")),
            cast("int | None", good.get("solver_effort")),
            cast("int | None", good.get("solver_jobs")),
        ),
        problems,
    )


def _key_span(source: SourceFile, key: str) -> Span:
    match = re.search(rf"^[ \t]*\"?{re.escape(key)}\"?[ \t]*=", source.text, re.MULTILINE)
    if match is None:
        return source.span(0, 0)
    start = match.start() + len(match.group()) - len(match.group().lstrip())
    return source.span(start, start + len(key))


def _toml_text(value: object) -> str:
    text = repr(value) if not isinstance(value, str) else f'"{value}"'
    return text if len(text) <= 40 else text[:37] + "..."


__all__ = ["CheckResult", "UsageError", "check"]
