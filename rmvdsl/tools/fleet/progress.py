"""Progress of a fleet replay on standard error: a bar redrawn in place on a terminal
(recordings done of all, messages a second, time left), a plain line every few
seconds otherwise (a CI log), nothing with --quiet."""

from __future__ import annotations

import time
from typing import TextIO

from rmvdsl.runtime.wording import counted

WIDTH = 24
EVERY = 10.0  # seconds between plain lines


class Progress:
    """`total` recordings, in `units` pieces of work (a recording each, or with
    --chunk one per chunk of a long one)."""

    def __init__(self, stream: TextIO | None, total: int, terminal: bool,
                 units: int | None = None) -> None:  # fmt: skip
        self.stream = stream
        self.total = total
        self.units = total if units is None else units
        self.chunked = units is not None and units != total
        self.terminal = terminal
        self.began = time.monotonic()
        self.last_line = self.began
        self.done = 0  # recordings
        self.units_done = 0
        self.messages = 0

    def finished(self, messages: int, *, recordings: int = 1, units: int = 1) -> None:
        """Recordings and units of work done, having read `messages`: a recording is
        one of each; a chunk is a unit; a chunked recording, once joined, a recording."""
        self.units_done += units
        self.done += recordings
        self.messages += messages
        if self.stream is None:
            return
        now = time.monotonic()
        last = self.done == self.total
        if self.terminal:
            self.stream.write("\r" + self.line(now))
            if last:
                self.stream.write("\n")
        elif now - self.last_line >= EVERY or last:
            self.last_line = now
            self.stream.write(f"rmv replay: {self.line(now)}\n")
        self.stream.flush()

    def clear(self) -> None:
        """Before a line of output on the same terminal."""
        if self.stream is not None and self.terminal and self.done < self.total:
            self.stream.write("\r\033[K")

    def line(self, now: float) -> str:
        elapsed = max(now - self.began, 1e-9)
        rate = self.messages / elapsed
        share = min(self.units_done, self.units) / self.units if self.units else 1.0
        left = elapsed / share * (1 - share) if share else 0.0
        filled = int(WIDTH * share)
        bar = f"[{'#' * filled}{'.' * (WIDTH - filled)}] " if self.terminal else ""
        recordings = counted(self.total, "recording", grouped=True)
        done = f"{self.units_done:,}/{counted(self.units, 'chunk', grouped=True)}"
        chunks = f" ({done})" if self.chunked else ""
        return (f"{bar}{self.done:,}/{recordings}{chunks}, {rate:,.0f} msg/s, "
                f"{_clock(elapsed)} elapsed, {_clock(left)} left")  # fmt: skip


def _clock(seconds: float) -> str:
    whole = round(seconds)
    hours, rest = divmod(whole, 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}" if hours else f"{rest // 60}:{rest % 60:02d}"
