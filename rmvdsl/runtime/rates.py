"""A topic's declared `max_rate` (docs/runtime.md, "Declared rates"): which messages
come faster than the spec says the topic publishes. Standard library only.

A topic declared at R Hz may carry ceil(R * W) messages in any window of W =
max(1 s, 1/R) seconds (a topic slower than 1 Hz: one message per 1/R). Each
message past that, by receipt time, is counted; it is still read (a flood is
reported, never silently thinned). Receipt, not `header.stamp`: a publisher
chooses its stamps, not when its messages arrive.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from fractions import Fraction

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.records import NS
from rmvdsl.runtime.values import exact_text


class RateLimit:
    """The receipt times of a topic's newest `allowed` messages."""

    def __init__(self, hertz: Fraction) -> None:
        self.hertz = hertz
        seconds = window(hertz)
        self.window_ns = math.ceil(seconds * NS)
        self.allowed = math.ceil(hertz * seconds)
        self.recent: deque[int] = deque(maxlen=self.allowed)
        self.newest = -1 << 63  # the newest receipt time seen, counted or not

    def exceeded(self, time: int) -> bool:
        """Whether a message received at `time` (ns, in order) is one more than the
        window allows. Only messages within the allowance are remembered, so what
        is counted is the excess: 100 messages a second on a 20 Hz topic count 80."""
        recent = self.recent
        self.newest = time
        if len(recent) == self.allowed and time - recent[0] < self.window_ns:
            return True
        recent.append(time)
        return False

    def state(self) -> tuple[int, ...]:
        """What decides the counts from here on (rmvdsl.runtime.seams): the
        remembered times a later message can still fall within a window of. Older
        ones act as if absent: every later message is more than a window after."""
        return tuple(t for t in self.recent if t > self.newest - self.window_ns)

    def words(self) -> str:
        """The declared limit as the spec's reader knows it: `20Hz: 20 in any 1 s`."""
        seconds = exact_text(Fraction(self.window_ns, NS))
        return f"{exact_text(self.hertz)}Hz: {self.allowed} in any {seconds} s"


def window(hertz: Fraction) -> Fraction:
    """The window (seconds) a topic declared at `hertz` is counted over."""
    return max(Fraction(1), 1 / hertz)


def limits(topics: Iterable[ir.Topic]) -> dict[str, RateLimit]:
    """A rate limit per ROS topic that declares a `max_rate`."""
    return {t.ros_name: RateLimit(t.max_rate) for t in topics if t.max_rate is not None}
