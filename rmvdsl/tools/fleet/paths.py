"""Which recordings `rmv replay` was given: files, rosbag2 folders, folders searched
for recordings, and patterns; every one found, in a stable order, none twice."""

from __future__ import annotations

import glob
import os
from collections.abc import Iterator, Sequence
from pathlib import Path

from rmvdsl.tools.recordings import ReplayError

SUFFIXES = (".bag", ".mcap", ".db3")
_PATTERN = "*?["


def is_pattern(text: str) -> bool:
    """A path with glob characters that names no existing file."""
    return any(c in text for c in _PATTERN) and not os.path.lexists(text)


def is_rosbag2_folder(path: Path) -> bool:
    return (path / "metadata.yaml").is_file()


def is_search(text: str) -> bool:
    """A pattern, or a folder that is not itself a recording: searched."""
    path = Path(text)
    return is_pattern(text) or (path.is_dir() and not is_rosbag2_folder(path))


def recordings(arguments: Sequence[str]) -> list[Path]:
    """The recordings the arguments name. A file is a recording (one that is not
    is reported as unreadable, never skipped); a folder with metadata.yaml is a
    rosbag2 recording; any other folder is searched for both."""
    found: dict[Path, None] = {}
    for text in arguments:
        matches = sorted(glob.glob(text, recursive=True)) if is_pattern(text) else [text]
        if not matches:
            raise ReplayError(f"{text}: no file or folder matches")
        for match in matches:
            for path in _expand(Path(match)):
                found.setdefault(path, None)
    return list(found)


def _expand(path: Path) -> list[Path]:
    if not os.path.lexists(path):
        raise ReplayError(f"{path}: no such file or directory")
    if not path.is_dir() or is_rosbag2_folder(path):
        return [path]
    inside = sorted(_search(path))
    if not inside:
        raise ReplayError(
            f"{path}: no recordings in it (.bag, .mcap or .db3 files, or rosbag2 folders)"
        )
    return inside


def _search(folder: Path) -> Iterator[Path]:
    """Recordings below `folder`, linked folders followed (each real folder once)."""
    seen: set[str] = set()
    for root, dirs, files in os.walk(folder, followlinks=True):
        real = os.path.realpath(root)
        if real in seen:
            dirs.clear()
            continue
        seen.add(real)
        here = Path(root)
        bags = sorted(d for d in dirs if is_rosbag2_folder(here / d))
        dirs[:] = sorted(d for d in dirs if d not in bags)
        yield from (here / d for d in bags)
        yield from (here / name for name in sorted(files) if name.endswith(SUFFIXES))
