"""Exceptions the command line catches, in a module that imports nothing, so that
`rmv --version` and `rmv --help` load no checker."""

from __future__ import annotations

# Exit codes of every command (docs/cli.md).
EXIT_OK, EXIT_ERRORS, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 70


class UsageError(Exception):
    """A problem with the command line's own input (exit code 2), not with a spec."""
