"""`rmv check` as the command line runs it: a re-check of unchanged inputs
answers from the store (no checker imported); otherwise rmvdsl.commands.check."""

from __future__ import annotations

import argparse
import sys

from rmvdsl.commands import message_options, use_color


def run(args: argparse.Namespace) -> int:
    from rmvdsl.commands import stored

    message_options(args)
    # A re-check of unchanged inputs prints what the last one printed (docs/cli.md).
    asked = [f"{k}={v!r}" for k, v in sorted(vars(args).items()) if k != "func"]
    entry = None if args.witnesses else stored.key([*asked, f"color={use_color(args)}"])
    output = stored.lookup(entry) if entry else None
    if output is None:
        from rmvdsl.commands import check  # the checker: only when there is checking to do

        output = check.run(args, use_color(args), entry)
    sys.stdout.write(output.stdout)
    sys.stderr.write(output.stderr)
    return output.code
