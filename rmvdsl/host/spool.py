"""Points waiting on disk: the collector's overflow while InfluxDB is away, bounded
in bytes, kept across restarts of the node (what one run could not write, the next
writes once InfluxDB answers).

One line per point: its arrival time (integer nanoseconds), a tab, the point's line
protocol (which holds no newline: line protocol escapes them). Points are taken
from the front; when all are taken the file is emptied."""

from __future__ import annotations

import os
from pathlib import Path


class Spool:
    def __init__(self, path: str, bound: int) -> None:
        self.path = Path(path)
        self.bound = bound  # bytes the file may grow to before it is drained
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.file = open(self.path, "a+b")  # noqa: SIM115 (open for the node's life)
        self.file.seek(0)
        self.read_at = self.count = self.size = 0
        for raw in self.file:  # what an earlier run left
            if not raw.endswith(b"\n"):
                break  # cut short when that run was killed: dropped below
            self.count += 1
            self.size += len(raw)
        self.file.truncate(self.size)

    def __len__(self) -> int:
        return self.count

    def push(self, line: str, arrival: int) -> bool:
        """Keep a point; False when the spool is full (the caller drops it)."""
        data = f"{arrival}\t{line}\n".encode()
        if self.size + len(data) > self.bound:
            return False
        self.file.seek(0, os.SEEK_END)
        self.file.write(data)
        self.size += len(data)
        self.count += 1
        return True

    def take(self, wanted: int) -> list[tuple[str, int]]:
        """Up to `wanted` of the oldest points (they are gone from the spool)."""
        self.file.flush()
        self.file.seek(self.read_at)
        found: list[tuple[str, int]] = []
        while len(found) < wanted:
            raw = self.file.readline()
            if not raw.endswith(b"\n"):
                break
            arrival, _, line = raw.decode().rstrip("\n").partition("\t")
            found.append((line, int(arrival)))
        self.read_at = self.file.tell() if found else self.read_at
        self.count -= len(found)
        if self.count == 0:  # all written: start the file afresh
            self.file.truncate(0)
            self.read_at = self.size = 0
        return found

    def close(self) -> None:
        """Keep only what was not taken, for the next run."""
        self.file.flush()
        if self.read_at:
            self.file.seek(self.read_at)
            rest = self.file.read()
            self.file.seek(0)
            self.file.truncate(0)
            self.file.write(rest)
        self.file.close()
