"""How a count reads in a message: "1 error", "2 errors" (the one place that
chooses a noun's number; tests/test_wording.py finds counts written without it);
how the system's refusals read (the one place that words an OSError); and text
made safe for a terminal (`visible`)."""

from __future__ import annotations


def counted(number: int, noun: str, plural: str | None = None, *, grouped: bool = False) -> str:
    """`number` and `noun`, plural unless number is 1 (`plural`: an irregular form;
    `grouped`: thousands separated by commas)."""
    shown = f"{number:,}" if grouped else str(number)
    return f"{shown} {noun if number == 1 else plural or noun + 's'}"


def visible(text: str) -> str:
    """Control characters as their Unicode pictures (NUL as ␀): a message or a line
    of a file never moves the cursor, rings the bell or paints the terminal. Every
    line rmv writes for a person passes through it: names and words from specs,
    traces, recordings and the ROS graph are anyone's (a ROS 1 node registers any
    caller id it likes)."""
    return text.translate(_PICTURES)


_PICTURES = {code: 0x2400 + code for code in range(32) if code not in (9, 10)}
_PICTURES |= {0x7F: 0x2421, **{code: 0xFFFD for code in range(0x80, 0xA0)}}


# What the system's refusals mean where rmv reads, writes or connects, in a user's words.
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
    "ECONNREFUSED": "connection refused: nothing listens there",
    "ETIMEDOUT": "no answer in time",
}


def os_words(error: OSError) -> str:
    """An OSError as words (not Python's `File exists` or `[Errno 111] ...`)."""
    import errno

    name = errno.errorcode.get(error.errno or 0, "")
    if name in _OS_WORDS:
        return _OS_WORDS[name]
    if isinstance(error, TimeoutError):
        return _OS_WORDS["ETIMEDOUT"]
    text = error.strerror or str(error) or type(error).__name__
    return text[0].lower() + text[1:]
