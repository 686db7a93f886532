"""Exceptions the command line catches, in a module that imports nothing, so that
`rmv --version` and `rmv --help` load no checker."""

from __future__ import annotations

# Exit codes of every command (docs/cli.md).
EXIT_OK, EXIT_ERRORS, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 70


class UsageError(Exception):
    """A problem with the command line's own input (exit code 2), not with a spec."""


# What the system's refusals mean where rmv reads or writes a path, in a user's words.
_OS_WORDS = {
    "EEXIST": "a file is in the way: a folder is needed there",
    "ENOTDIR": "a part of the path is a file, not a folder",
    "EISDIR": "it is a folder, not a file",
    "ENOENT": "no such file or folder",
    "EACCES": "permission denied",
    "EPERM": "permission denied",
    "ENOSPC": "the disk is full",
    "EROFS": "the file system is read-only",
    "ENAMETOOLONG": "the name is too long",
}


def os_problem(error: OSError) -> str:
    """An OSError as words (not Python's `File exists` or `[Errno 20]`)."""
    import errno

    name = errno.errorcode.get(error.errno or 0, "")
    if name in _OS_WORDS:
        return _OS_WORDS[name]
    text = error.strerror or str(error) or type(error).__name__
    return text[0].lower() + text[1:]
