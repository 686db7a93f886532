"""Reading a file's text as every command does: UTF-8, a byte-order mark dropped,
and a one-line reason (UsageError) when it cannot be read. Apart from the checker,
so a command that only reads text (`rmv fmt`) does not load the checker's stages."""

from __future__ import annotations

from rmvdsl.lang.errors import UsageError, unreadable


def read_text(path: str) -> str:
    """Read a UTF-8 file; raise UsageError with a one-line reason otherwise."""
    try:
        with open(path, "rb") as handle:
            data = handle.read()
    except OSError as exc:
        raise unreadable(path, exc) from None
    return decode(data, path)


def read_stdin() -> str:
    """Standard input, read as a file is: UTF-8, a byte-order mark dropped."""
    import sys

    return decode(sys.stdin.buffer.read(), "<stdin>")


def decode(data: bytes, path: str) -> str:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UsageError(
            f"{path}: not UTF-8 text (invalid byte 0x{data[exc.start]:02x} at offset {exc.start})"
        ) from None
    return text.removeprefix("\ufeff")
