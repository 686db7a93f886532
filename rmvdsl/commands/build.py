"""`rmv build` and `rmv targets`: a target of the registry, built from a spec
that checks clean."""

from __future__ import annotations

import argparse
import sys

from rmvdsl import targets
from rmvdsl.commands import message_options, say
from rmvdsl.lang.errors import EXIT_OK, UsageError
from rmvdsl.runtime.wording import os_words


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from rmvdsl.commands import stored_spec

    message_options(args)
    spec = stored_spec.checked("build", args.spec, args.ros, args.messages, refuse_empty=False)
    if isinstance(spec, int):
        return spec
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
        say(f"rmv build: {line}")
    if built.text is not None:
        sys.stdout.write(built.text)
    elif built.summary:
        say(f"rmv build: {built.summary}", sys.stdout)
    return EXIT_OK


def list_targets(args: argparse.Namespace) -> int:
    for target in targets.targets():
        options = "".join(f" [{o.flag} {o.metavar}]" for o in target.options)
        out = "-o FILE" if target.output == "file" else "-o FOLDER"
        say(f"{target.name:<10} {target.summary} ({out}{options}; {target.docs})", sys.stdout)
    return EXIT_OK
