"""A light scan of a .rmv file ahead of the parser.

It finds comments (the formatter and doc comments need them) and the lines where a
top-level declaration starts. The parser parses each declaration on its own, so a
syntax error in one never hides the errors of the next: that is the coarse level
of error recovery; the token-level level is in `parser.py`.
"""

from __future__ import annotations

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

_OPENERS = {"{": "}", "(": ")", "[": "]"}
_CLOSERS = frozenset(_OPENERS.values())


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


def scan(text: str) -> ScanResult:
    comments: list[RawComment] = []
    chunks: list[tuple[int, int]] = [(0, 1)]
    depth = 0
    offset = 0
    for line_number, line in enumerate(text.split("\n"), 1):
        if _starts_declaration(line, depth):
            depth = 0
            if offset != chunks[-1][0]:
                chunks.append((offset, line_number))
        depth = _scan_line(line, offset, depth, comments)
        offset += len(line) + 1
    return ScanResult(tuple(comments), tuple(chunks))


def _scan_line(line: str, offset: int, depth: int, comments: list[RawComment]) -> int:
    index = 0
    length = len(line)
    while index < length:
        char = line[index]
        if char == '"':
            index += 1
            while index < length and line[index] != '"':
                index += 2 if line[index] == "\\" else 1
        elif char == "/" and line.startswith("//", index):
            own_line = not line[:index].strip()
            text = line[index:].rstrip("\r")
            comments.append(RawComment(offset + index, offset + index + len(text), text, own_line))
            break
        elif char in _OPENERS:
            depth += 1
        elif char in _CLOSERS:
            depth = max(0, depth - 1)
        index += 1
    return depth
