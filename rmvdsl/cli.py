"""The `rmv` command: a thin layer over the checker, formatter and importers.

Exit codes: 0 no errors, 1 errors found (or `fmt --check` would change a file),
2 usage or I/O problem, with a one-line message and never a traceback.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import importlib
import os
import sys
import threading
from collections.abc import Sequence

from rmvdsl.commands import say
from rmvdsl.commands.arguments import build_parser
from rmvdsl.lang.errors import EXIT_INTERNAL, EXIT_OK, EXIT_USAGE, UsageError
from rmvdsl.util.deep import deep


def main(argv: Sequence[str] | None = None) -> int:
    arguments = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(arguments)
    args = parser.parse_args(arguments)
    if args.command is None:
        parser.print_help()
        return EXIT_USAGE
    try:
        return deep(_run, args)
    except UsageError as exc:
        say(f"rmv: error: {exc}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # a bug in rmv: say so in one line, never a traceback
        if os.environ.get("RMV_DEBUG"):
            raise
        say(
            f"rmv: internal error: {type(exc).__name__}: {exc} "
            "(please report it; RMV_DEBUG=1 shows where)"
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
        say(f"rmv: error: unknown code `{code}`; known codes: {known}")
        return EXIT_USAGE
    sys.stdout.write(text)
    return EXIT_OK


def entry() -> None:
    """The `rmv` console script: main(), then out of the process without freeing
    what the command built, one object at a time. A first check of a 16,000-line
    spec holds millions of objects, and the interpreter's own exit freed them for
    1.05 s after the last line was printed; the system takes the memory back at
    once. Streams are flushed and exit handlers run (the solver's workers are
    stopped) as at any exit; a command that left a thread running exits the
    usual way, which waits for it."""
    code = main()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe: nothing more to say
            stream.flush()
    running = [
        t for t in threading.enumerate() if not t.daemon and t is not threading.current_thread()
    ]
    run_handlers = getattr(atexit, "_run_exitfuncs", None)
    if running or run_handlers is None:
        sys.exit(code)
    run_handlers()
    os._exit(code)


if __name__ == "__main__":
    entry()
