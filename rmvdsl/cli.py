"""The `rmv` command: a thin layer over the checker, formatter and importers.

Exit codes: 0 no errors, 1 errors found (or `fmt --check` would change a file),
2 usage or I/O problem, with a one-line message and never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from rmvdsl.commands.arguments import build_parser
from rmvdsl.lang.errors import EXIT_INTERNAL, EXIT_OK, EXIT_USAGE, UsageError
from rmvdsl.util.deep import deep


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return EXIT_USAGE
    try:
        return deep(_run, args)
    except UsageError as exc:
        print(f"rmv: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # a bug in rmv: say so in one line, never a traceback
        if os.environ.get("RMV_DEBUG"):
            raise
        print(
            f"rmv: internal error: {type(exc).__name__}: {exc} "
            "(please report it; RMV_DEBUG=1 shows where)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


# Each command's module and function (imported when the command runs, so that
# `rmv --help` and a stored re-check load nothing more).
COMMANDS = {
    "build": ("build", "run"),
    "targets": ("build", "list_targets"),
    "check": ("checking", "run"),
    "deploy": ("deploy", "run"),
    "fmt": ("fmt", "run"),
    "import": ("imports", "run"),
    "eval": ("formula", "run_eval"),
    "sat": ("formula", "run_sat"),
    "graph": ("graph", "run"),
    "replay": ("replay", "run"),
}


def _run(args: argparse.Namespace) -> int:
    if args.command == "lsp":
        return _lsp(args)
    if args.command == "explain":
        return _explain(args.code)
    module, function = COMMANDS[args.command]
    command = getattr(importlib.import_module(f"rmvdsl.commands.{module}"), function)
    code: int = command(args)
    return code


def _lsp(args: argparse.Namespace) -> int:
    from rmvdsl.editor.lsp.server import main

    main()
    return EXIT_OK


def _explain(code: str) -> int:
    from rmvdsl.lang.codes import CODES, explain

    text = explain(code)
    if text is None:
        known = ", ".join(sorted(CODES))
        print(f"rmv: error: unknown code `{code}`; known codes: {known}", file=sys.stderr)
        return EXIT_USAGE
    sys.stdout.write(text)
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
