"""`rmv replay`: a spec over recordings (rmvdsl.tools.replay does the work)."""

from __future__ import annotations

import argparse
import sys

from rmvdsl.commands import message_options
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK, EXIT_USAGE, UsageError
from rmvdsl.runtime.wording import counted


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from rmvdsl.check import check
    from rmvdsl.ir import lower
    from rmvdsl.lang.render import render_text
    from rmvdsl.tools import replay

    message_options(args)
    if args.report:
        from rmvdsl.tools.report import unavailable

        reason = unavailable(args.report)
        if reason is not None:
            raise UsageError(reason)
    result = check(args.spec, ros=args.ros, messages=tuple(args.messages))
    if result.errors:
        sys.stderr.write(render_text(result.errors, result.model.sources, False))
        print(f"rmv replay: {args.spec}: {counted(len(result.errors), 'error')}", file=sys.stderr)
        return EXIT_ERRORS
    progress = replay.progress_bar() if sys.stderr.isatty() else None
    try:
        summary = replay.run(
            lower(result), [Path(p) for p in args.recordings], sys.stdout,
            output=args.format, start=args.start, stop=args.stop, report=args.report,
            run_actions=args.run_actions, progress=progress,
        )  # fmt: skip
    except (replay.ReplayError, ValueError, ZeroDivisionError) as exc:
        raise UsageError(str(exc)) from None
    if summary.failed:
        return EXIT_ERRORS
    # Input lost to a mismatch with the spec: the verdicts cannot be trusted.
    return EXIT_USAGE if summary.warnings else EXIT_OK
