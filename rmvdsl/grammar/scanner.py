"""A light scan of a .rmv file ahead of the parser.

It finds comments (the formatter and doc comments need them) and the lines where a
top-level declaration starts. The parser parses each declaration on its own, so a
syntax error in one never hides the errors of the next: that is the coarse level
of error recovery; the token-level level is in `parser.py`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

TOP_LEVEL_KEYWORDS = frozenset(
    {
        "system",
        "import",
        "time",
        "database",
        "topic",
        "var",
        "event",
        "alert",
        "transducer",
        "property",
        "whitelist",
        "node",
        "intrusion",
        "ros",
        "messages",
    }
)


@dataclass(frozen=True)
class RawComment:
    start: int
    end: int
    text: str
    own_line: bool  # nothing but blanks before it on its line


@dataclass(frozen=True)
class ScanResult:
    comments: tuple[RawComment, ...]
    # (offset, 1-based line) of each chunk; the first chunk starts at offset 0.
    chunks: tuple[tuple[int, int], ...]


def _leading_word(line: str) -> tuple[str, int]:
    stripped = line.lstrip(" \t")
    indent = len(line) - len(stripped)
    end = 0
    while end < len(stripped) and (stripped[end].isalnum() or stripped[end] == "_"):
        end += 1
    return stripped[:end], indent


def _starts_declaration(line: str, depth: int) -> bool:
    word, indent = _leading_word(line)
    if word not in TOP_LEVEL_KEYWORDS:
        return False
    if word == "time":
        # `time(100ms)` continues a group-by clause; only `time unit` declares.
        rest = line.lstrip(" \t")[4:].lstrip(" \t")
        if not (rest.startswith("unit") and (len(rest) == 4 or not rest[4].isalnum())):
            return False
    # Inside an unclosed block, only an unindented keyword starts a new declaration:
    # a forgotten `}` then costs one error, not the rest of the file.
    return depth == 0 or indent == 0


# What the scan looks at, in one pass over the text (an editor scans the whole file
# at every keystroke; a loop over every character was a seventh of an edit): a line
# opening with a top-level keyword (`\w` is `isalnum()` or `_`, as in
# `_leading_word`), a string (it ends at its line's end, as the grammar's do), a
# comment, and brackets. Lines never continue a string or a comment, so a line's
# start is never inside one.
_TOKENS = re.compile(
    r"(?P<keyword>^[ \t]*(?:" + "|".join(sorted(TOP_LEVEL_KEYWORDS)) + r")(?!\w))"
    r'|"(?:[^"\\\n]|\\[^\n])*"?'
    r"|(?P<comment>//[^\n]*)"
    r"|(?P<open>[{(\[])"
    r"|(?P<close>[})\]])",
    re.MULTILINE,
)


def scan(text: str) -> ScanResult:
    comments: list[RawComment] = []
    chunks: list[tuple[int, int]] = [(0, 1)]
    depth = 0
    counted, line_number = 0, 1  # newlines counted up to `counted`
    for match in _TOKENS.finditer(text):
        kind, start = match.lastgroup, match.start()
        if kind == "open":
            depth += 1
        elif kind == "close":
            depth = max(0, depth - 1)
        elif kind == "keyword":
            if _declares(text, match, depth):
                depth = 0
                if start != chunks[-1][0]:
                    line_number += text.count("\n", counted, start)
                    counted = start
                    chunks.append((start, line_number))
        elif kind == "comment":
            line_start = text.rfind("\n", 0, start) + 1
            own_line = not text[line_start:start].strip()
            found = match.group().rstrip("\r")
            comments.append(RawComment(start, start + len(found), found, own_line))
    return ScanResult(tuple(comments), tuple(chunks))


def _declares(text: str, keyword: re.Match[str], depth: int) -> bool:
    """Whether the line of a leading keyword starts a declaration."""
    if depth == 0 and not keyword.group().endswith("time"):
        return True  # the common case, without reading the line again
    start = keyword.start()
    end = text.find("\n", start)
    return _starts_declaration(text[start:] if end == -1 else text[start:end], depth)
