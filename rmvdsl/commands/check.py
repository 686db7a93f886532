"""`rmv check`: check each spec, render every diagnostic, and store the output
with the inputs it read (rmvdsl.commands.stored answers the next unchanged run)."""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import sys
import time
from typing import Any

from rmvdsl.check import CheckResult
from rmvdsl.check.msgfolders import folders_read
from rmvdsl.check.properties import PropertyReport
from rmvdsl.commands import say, stored, write_text
from rmvdsl.editor.workspace import Workspace
from rmvdsl.lang.diagnostics import Diagnostic, Severity, error
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK, EXIT_USAGE, UsageError
from rmvdsl.lang.render import render_json, render_sarif, render_text, summary
from rmvdsl.lang.source import SourceMap, Span
from rmvdsl.logic.parallel import Progress, progress
from rmvdsl.runtime.wording import counted, os_words, visible


def run(args: argparse.Namespace, color: bool, entry: str | None) -> stored.Stored:
    """Check `args.files` as `rmv check` was asked; the output, stored under
    `entry` when it may answer a later run."""
    all_diagnostics: list[Diagnostic] = []
    sources = SourceMap()
    usage_problems: list[str] = []
    checked: list[str] = []
    workspace = Workspace()  # as `rmv lsp` checks, with no document open
    shown = progress(solver_bar(sys.stderr)) if sys.stderr.isatty() else contextlib.nullcontext()
    with shown:
        _check_files(args, workspace, all_diagnostics, sources, usage_problems, checked)
    out = io.StringIO()
    if args.format == "json":
        out.write(render_json(all_diagnostics, sources))
    elif args.format == "sarif":
        out.write(render_sarif(all_diagnostics, sources))
    else:
        out.write(render_text(all_diagnostics, sources, color))
        if checked:
            out.write(summary(checked, all_diagnostics) + "\n")
    failing = {Severity.ERROR, Severity.WARNING} if args.strict else {Severity.ERROR}
    failed = any(d.severity in failing for d in all_diagnostics)
    code = EXIT_USAGE if usage_problems else EXIT_ERRORS if failed else EXIT_OK
    output = stored.Stored(out.getvalue(), "".join(usage_problems), code)
    if entry and not usage_problems and stored.storable(d.code for d in all_diagnostics):
        stored.store(entry, output, stored.inputs(checked, sources), folders_read())
    return output


_NAME = re.compile(r'[\w/]+|"(?:[^"\\]|\\.)*"')


def target_diagnostics(result: CheckResult, name: str) -> list[Diagnostic]:
    """What the target `name` says of a spec that checks clean, at the declarations
    it names (the `system` declaration when it names none)."""
    from rmvdsl.ir import lower
    from rmvdsl.targets import target

    found = []
    for finding in target(name).findings(lower(result)):
        span = _span_of(result, finding.origin)
        if finding.severity == "error":
            found.append(
                error("RMV600", finding.message, span,
                      label=f"the {name} target cannot build this",
                      help=finding.help or None)
            )  # fmt: skip
        else:
            found.append(
                Diagnostic("RMV601", Severity.NOTE, finding.message, span,
                           f"left out by the {name} target", help=finding.help or None)
            )  # fmt: skip
    return found


def _span_of(result: CheckResult, origin: str) -> Span:
    """The span of the name at `origin` ("path:line:column"), or the root file's
    first line."""
    path, _, place = origin.rpartition(":")
    path, _, line = path.rpartition(":")
    source = result.model.sources.get(path) if path else None
    if source is None or not line.isdigit() or not place.isdigit():
        system = result.model.system
        if system is not None:
            return system.name.span
        root = result.model.root
        first = result.model.sources.get(root.path) if root is not None else None
        if first is None:
            first = next(iter(result.model.sources))
        return first.span(0, len(first.line_text(1)))
    start = source.offset(int(line), int(place))
    name = _NAME.match(source.text, start)
    return source.span(start, name.end() if name else start + 1)


def write_witnesses(folder: str, report: PropertyReport, unit: str | None = None) -> None:
    """For each property, a trace where it holds and one where it fails (JSONL), its
    times in the spec's time unit, which the file says (`rmv eval` reads it)."""
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--witnesses {folder}: {os_words(exc)}") from None
    for name, facts in report.facts.items():
        found = [
            ("holds", "true", facts.satisfiable),
            ("fails", "false", facts.valid),
        ]
        for suffix, verdict, answer in found:
            if answer is None or answer.witness is None:
                continue
            if (suffix == "holds") != (answer.value == "yes"):
                continue
            path = os.path.join(folder, f"{name}.{suffix}.jsonl")
            write_text(path, answer.witness.jsonl(unit))
            at = answer.witness.as_json()["at"]
            suffix = f" {unit}" if unit not in (None, "s") else ""
            say(f"rmv: {path}: `{name}` is {verdict} at t = {at}{suffix}")


def _check_files(
    args: argparse.Namespace,
    workspace: Workspace,
    all_diagnostics: list[Diagnostic],
    sources: SourceMap,
    usage_problems: list[str],
    checked: list[str],
) -> None:
    """Check each file, collecting what `run` prints."""
    for path in args.files:
        try:
            result = workspace.check(
                path,
                ros=args.ros,
                messages=tuple(args.messages),
                solver_timeout=args.timeout,
                solver_jobs=args.jobs,
            )
        except UsageError as exc:
            usage_problems.append(visible(f"rmv: error: {exc}") + "\n")
            continue
        checked.append(path)
        all_diagnostics.extend(result.diagnostics)
        if args.target and not result.errors:
            all_diagnostics.extend(target_diagnostics(result, args.target))
        if args.witnesses and result.properties is not None:
            write_witnesses(args.witnesses, result.properties, result.model.time_unit)
        for source in result.model.sources:
            sources.add(source)


def solver_bar(stream: Any) -> Progress:
    """The solver's progress, one line redrawn in place, once its work has taken
    2 s (a quick check prints nothing more; RMV_PROGRESS_AFTER sets the seconds),
    cleared when a stage ends."""
    started = time.monotonic()
    after = float(os.environ.get("RMV_PROGRESS_AFTER", "2"))

    def draw(done: int, total: int) -> None:
        if time.monotonic() - started < after:
            return
        filled = int(30 * done / total)
        tasks = counted(total, "task", grouped=True)
        line = f"[{'#' * filled}{'.' * (30 - filled)}] solver: {done:,}/{tasks}"
        stream.write(f"\r{line}" if done < total else "\r" + " " * len(line) + "\r")
        stream.flush()

    return draw
