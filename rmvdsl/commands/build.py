"""`rmv build` and `rmv targets`: a target of the registry, built from a spec
that checks clean."""

from __future__ import annotations

import argparse
import sys

from rmvdsl import targets
from rmvdsl.commands import message_options, warn_if_nothing_checked
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK, UsageError
from rmvdsl.runtime.wording import counted, os_words


def run(args: argparse.Namespace) -> int:
    from rmvdsl.check import check
    from rmvdsl.ir import lower
    from rmvdsl.lang.render import render_text

    message_options(args)
    result = check(args.spec, ros=args.ros, messages=tuple(args.messages))
    if result.errors:
        sys.stderr.write(render_text(result.errors, result.model.sources, False))
        print(
            f"rmv build: {args.spec}: {counted(len(result.errors), 'error')}: nothing built",
            file=sys.stderr,
        )
        return EXIT_ERRORS
    from pathlib import Path

    warn_if_nothing_checked(result)
    spec = lower(result)
    target = targets.target(args.target)
    options = {o.name: getattr(args, o.name) for o in target.options}
    for other in targets.targets():  # an option of another target is a mistake
        for option in other.options:
            if other is not target and getattr(args, option.name) is not None:
                raise UsageError(f"{option.flag} is an option of --target {other.name}")
    out = Path(args.output) if args.output else None
    try:
        built = target.build(spec, out, options)
    except targets.TargetError as exc:
        raise UsageError(str(exc)) from None
    except OSError as exc:
        raise UsageError(f"{args.output}: {os_words(exc)}") from None
    for line in built.notes:
        print(f"rmv build: {line}", file=sys.stderr)
    if built.text is not None:
        sys.stdout.write(built.text)
    elif built.summary:
        print(f"rmv build: {built.summary}")
    return EXIT_OK


def list_targets(args: argparse.Namespace) -> int:
    for target in targets.targets():
        options = "".join(f" [{o.flag} {o.metavar}]" for o in target.options)
        out = "-o FILE" if target.output == "file" else "-o FOLDER"
        print(f"{target.name:<10} {target.summary} ({out}{options}; {target.docs})")
    return EXIT_OK
