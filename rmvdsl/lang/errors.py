"""Exceptions the command line catches, in a module that imports nothing, so that
`rmv --version` and `rmv --help` load no checker."""

from __future__ import annotations

# Exit codes of every command (docs/cli.md).
EXIT_OK, EXIT_ERRORS, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 70


class UsageError(Exception):
    """A problem with the command line's own input (exit code 2), not with a spec."""


def unreadable(path: str, exc: OSError) -> UsageError:
    """Why a file cannot be read, in one line."""
    from rmvdsl.runtime.wording import os_words  # when there is a reason to word

    if isinstance(exc, FileNotFoundError):
        return UsageError(f"{path}: no such file")
    if isinstance(exc, IsADirectoryError):
        return UsageError(f"{path}: is a directory, not a file")
    if isinstance(exc, PermissionError):
        return UsageError(f"{path}: permission denied")
    return UsageError(f"{path}: cannot read: {os_words(exc)}")
