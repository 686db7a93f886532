"""The work of `rmv` commands that is more than parsing arguments (rmvdsl.cli
parses them and calls here). Light to import: each command imports the checker
only when it has to check."""

from __future__ import annotations

from rmvdsl.errors import UsageError


def write_text(path: str, text: str) -> None:
    """Write a file a command was asked to write; UsageError (exit 2) if it cannot."""
    try:
        with open(path, "w", encoding="utf-8") as handle:
            handle.write(text)
    except OSError as exc:
        raise UsageError(f"{path}: cannot write: {exc.strerror}") from None
