"""`rmv import`: the thesis's YAML files as one `.rmv` spec."""

from __future__ import annotations

import argparse
import sys

from rmvdsl.commands import say, write_text
from rmvdsl.lang.errors import EXIT_OK


def run(args: argparse.Namespace) -> int:
    from rmvdsl.importers.thesis_yaml import convert_files

    result = convert_files(args.files, system_name=args.name)
    for note in result.notes:
        say(f"rmv import: {note}")
    if args.output:
        write_text(args.output, result.text)
        say(f"wrote {args.output}")
    else:
        sys.stdout.write(result.text)
    return EXIT_OK
