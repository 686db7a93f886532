"""`rmv deploy`: apply a kapacitor build to InfluxDB and Kapacitor."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from rmvdsl.errors import EXIT_ERRORS, EXIT_OK, UsageError
from rmvdsl.runtime.wording import counted

if TYPE_CHECKING:
    pass


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from rmvdsl import deploy

    out = Path(args.out)
    if not (out / deploy.MANIFEST).is_file():
        raise UsageError(
            f"{out}: no {deploy.MANIFEST}: not a build of `rmv build --target kapacitor`"
        )
    try:
        report = deploy.deploy(out, args.influx, args.kapacitor)
    except deploy.DeployError as exc:
        print(f"rmv deploy: {exc}", file=sys.stderr)
        return EXIT_ERRORS
    for line in report.applied:
        print(f"rmv deploy: {line}")
    print(
        f"rmv deploy: {counted(len(report.applied), 'change')}, "
        f"{counted(len(report.unchanged), 'part')} already as built"
    )
    return EXIT_OK
