"""`rmv fmt`: the canonical layout, in place, to standard output, or `--check`."""

from __future__ import annotations

import argparse
import sys

from rmvdsl.commands import say, use_color, write_text
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK


def run(args: argparse.Namespace) -> int:
    from rmvdsl.grammar.formatter import format_source
    from rmvdsl.lang.files import read_stdin, read_text
    from rmvdsl.lang.render import render_text
    from rmvdsl.lang.source import SourceFile, SourceMap

    status = EXIT_OK
    for path in args.files:
        text = read_stdin() if path == "-" else read_text(path)
        source = SourceFile("<stdin>" if path == "-" else path, text)
        formatted, errors = format_source(source)
        if formatted is None:
            sources = SourceMap()
            sources.add(source)
            sys.stderr.write(render_text(errors, sources, use_color(args) and sys.stderr.isatty()))
            say(f"rmv: error: {source.path}: not formatted: fix the syntax errors first")
            status = EXIT_ERRORS
            continue
        if path == "-":
            sys.stdout.write(formatted)
        elif formatted != text:
            if args.check:
                say(f"would reformat {path}", sys.stdout)
                status = EXIT_ERRORS
            else:
                write_text(path, formatted)
                say(f"reformatted {path}", sys.stdout)
    return status
