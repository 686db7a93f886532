"""`rmv deploy`: apply a build to the services its target runs on (the kapacitor
target's: InfluxDB and Kapacitor), as the target declares it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rmvdsl import targets
from rmvdsl.commands import say
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK, UsageError


def run(args: argparse.Namespace) -> int:
    target = targets.target(args.target)
    assert target.deploy is not None  # the parser offers only targets that deploy
    options = {o.name: getattr(args, o.name) for o in target.deploy_options}
    try:
        deployed = target.deploy(Path(args.out), options)
    except targets.TargetError as exc:
        raise UsageError(str(exc)) from None
    if deployed.failed is not None:
        say(f"rmv deploy: {deployed.failed}")
        return EXIT_ERRORS
    for line in deployed.changes:
        say(f"rmv deploy: {line}", sys.stdout)
    say(f"rmv deploy: {deployed.summary}", sys.stdout)
    return EXIT_OK
