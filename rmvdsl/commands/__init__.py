"""The work of `rmv` commands that is more than parsing arguments (rmvdsl.cli
parses them and calls here). Light to import: each command imports the checker
only when it has to check."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any, TextIO

from rmvdsl.lang.errors import UsageError
from rmvdsl.runtime.wording import os_words, visible


def say(text: str, stream: TextIO | None = None) -> None:
    """A line for a person, on standard error unless `stream`: made safe for a
    terminal, as the names, paths and words in it come from specs, traces,
    recordings and the command line (rmvdsl.runtime.wording.visible). Every line of
    a command's own goes through here (tests/test_terminal.py); what a command
    prints as data (generated code, JSON, a formatted spec) is written as it is."""
    print(visible(text), file=sys.stderr if stream is None else stream)


def write_text(path: str, text: str) -> None:
    """Write a file a command was asked to write; UsageError (exit 2) if it cannot."""
    try:
        with open(path, "w", encoding="utf-8") as handle:
            handle.write(text)
    except OSError as exc:
        raise UsageError(f"{path}: cannot write: {os_words(exc)}") from None


def use_color(args: argparse.Namespace) -> bool:
    if getattr(args, "no_color", False) or os.environ.get("NO_COLOR"):
        return False
    return sys.stdout.isatty()


def message_options(args: argparse.Namespace) -> None:
    if args.ros is not None:
        from rmvdsl.check.msgtypes import DISTROS  # not on the path of a stored re-check

        if args.ros not in DISTROS:
            raise UsageError(f"unknown ROS distribution `{args.ros}`; known: {', '.join(DISTROS)}")
    for folder in args.messages:
        if not os.path.isdir(folder):
            raise UsageError(f"--messages {folder}: no such folder")


def warn_if_nothing_checked(result: Any) -> bool:
    """Say on standard error that the spec checks nothing (RMV226), if it does not:
    a package or a replay of it would pass anything. Whether it said so."""
    from rmvdsl.lang.render import render_text

    found = [d for d in result.diagnostics if d.code == "RMV226"]
    if found:
        sys.stderr.write(render_text(found, result.model.sources, False))
    return bool(found)
