"""How hard the solver may try: a time limit per call, the segment counts tried,
z3's deterministic effort, and how many worker processes."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Limits:
    timeout: float = 5.0  # seconds, for each solver call
    segments: tuple[int, ...] = (1, 2, 4, 8)
    effort: int | None = None  # z3's rlimit per call: deterministic, unlike time
    jobs: int | None = None  # worker processes (rmvdsl.logic.parallel); None: one a core

    def key(self) -> str:
        """What the answers depend on (not `jobs`: the same answers, sooner)."""
        return f"{self.timeout}:{self.segments}:{self.effort}"

    def quick(self) -> Limits:
        """A tenth of the limits (at most half a second), for a first attempt."""
        effort = None if self.effort is None else max(1, self.effort // 10)
        return Limits(min(self.timeout, 0.5), self.segments, effort, self.jobs)

    def configure(self, solver: Any) -> None:
        solver.set("timeout", max(1, int(self.timeout * 1000)))
        if self.effort is not None:
            solver.set("rlimit", self.effort)
