"""`rmv replay`: a spec over recordings (rmvdsl.tools.replay does the work)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from rmvdsl.commands import message_options
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK, EXIT_USAGE, UsageError


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from rmvdsl.tools import fleet, replay
    from rmvdsl.tools.recordings import ReplayError
    from rmvdsl.util import collection

    message_options(args)
    if args.report:
        from rmvdsl.tools.report import unavailable

        reason = unavailable(args.report)
        if reason is not None:
            raise UsageError(reason)
    from rmvdsl.commands import stored_spec

    spec = stored_spec.checked("replay", args.spec, args.ros, args.messages, refuse_empty=True)
    if isinstance(spec, int):
        return spec
    scheduler = fleet.scheduler_of(args.scheduler, args.dask)
    if args.merge and args.chunk is not None:
        raise UsageError("--chunk replays each recording on its own: leave out --merge")
    if not args.merge and fleet.is_fleet(args.recordings, scheduler, args.chunk):
        return _fleet(args, spec, scheduler)
    progress = replay.progress_bar() if sys.stderr.isatty() and not args.quiet else None
    try:
        with collection.for_streams():
            summary = replay.run(
                spec, [Path(p) for p in args.recordings], sys.stdout,
                output=args.format, start=args.start, stop=args.stop, report=args.report,
                run_actions=args.run_actions, progress=progress,
            )  # fmt: skip
    except (ReplayError, ValueError, ZeroDivisionError) as exc:
        raise UsageError(str(exc)) from None
    if summary.failed:
        return EXIT_ERRORS
    # Input lost to a mismatch with the spec: the verdicts cannot be trusted.
    return EXIT_USAGE if summary.warnings else EXIT_OK


def _fleet(args: argparse.Namespace, spec: Any, scheduler: str | None) -> int:
    """Several recordings: one result each (rmvdsl.tools.fleet)."""
    from rmvdsl.tools import fleet

    if args.report and not args.report.endswith(".html"):
        raise UsageError(f"--report {args.report}: over several recordings the report is one "
                         "page: give FILE.html")  # fmt: skip
    if args.run_actions:
        raise UsageError("--run-actions runs one recording's actions: give one recording")
    options = fleet.Options(start=args.start, stop=args.stop, timeout=args.timeout)
    settings = fleet.Settings(output=args.format, jobs=args.jobs, scheduler=scheduler,
                              report=args.report, quiet=args.quiet, options=options,
                              chunk=args.chunk)  # fmt: skip
    return fleet.run(spec, args.recordings, sys.stdout, settings)
