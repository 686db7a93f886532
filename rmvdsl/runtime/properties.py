"""One property's monitor: the state signal of its propositions, sampled at its
`rate` (or at every change), fed to an RMTLD3 monitor while its trigger holds."""

from __future__ import annotations

from typing import Any

from rmvdsl.runtime import influx
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.formulas import scaled, to_lists
from rmvdsl.runtime.records import NS, seconds
from rmvdsl.runtime.rmtld3 import Monitor


class PropertyMonitor:
    """One property: the state signal of its propositions, sampled at `rate` (or
    at every change), fed to an RMTLD3 monitor while `trigger` holds."""

    def __init__(self, prop: ir.Property, start: int, initial: frozenset[str]) -> None:
        self.prop = prop
        # The monitor reads times in integer nanoseconds, as the input comes: its
        # verdicts are turned into seconds as they are given out (`verdicts`).
        self.formula = to_lists(scaled(prop.formula, NS))
        self.names = frozenset(prop.propositions)
        self.watch = self.names | ({prop.trigger} if prop.trigger != "always" else set())
        self.true: set[str] = set(initial & self.watch)
        self.period = None if prop.rate is None else influx.nanoseconds(1 / prop.rate)
        self.next_tick = None if self.period is None else -(-start // self.period) * self.period
        self.pending_pulses: set[str] = set()
        self.monitor: Monitor | None = None
        self.segments: list[tuple] = []
        self.start = start
        # How far a verdict reads its input ahead and back (seconds): a verdict at s
        # reads the input on [s - past, s + future].
        self.future, self.past = prop.horizon_future, prop.horizon_past
        if self._triggered():
            self._open(start)

    def _triggered(self) -> bool:
        return self.prop.trigger == "always" or self.prop.trigger in self.true

    def _open(self, time: int) -> None:
        self.monitor = Monitor(self.formula)
        if self.period is None:
            self.monitor.step(time, self.true & self.names)

    def _close(self, time: int) -> None:
        if self.monitor is not None:
            self.monitor.end(time)
            self.segments.extend(map(_in_seconds, self.monitor.verdicts()))
            self.monitor = None

    def instant(self, time: int, changes: list[tuple[str, Any]]) -> None:
        self.ticks_before(time)
        was = self._triggered()
        pulses = set()
        for name, value in changes:
            if name not in self.watch:
                continue
            if value is True:
                self.true.add(name)
            else:
                if name in self.true and any(n == name and v is True for n, v in changes):
                    pulses.add(name)
                self.true.discard(name)
        now = self._triggered()
        if was and not now:
            self._close(time)
        elif now and not was:
            self._open(time)
        if self.monitor is None:
            return
        if self.period is None:
            self.monitor.step(time, self.true & self.names, pulses & self.names)
        else:
            self.pending_pulses |= pulses

    def ticks_before(self, bound: int) -> None:
        """Samples at the rate's ticks before `bound` (all that happened up to a
        tick is known once the input is final past it)."""
        if self.period is None or self.next_tick is None or self.next_tick >= bound:
            return
        state = self.true & self.names
        if self.monitor is not None:
            self.monitor.step(self.next_tick, state, self.pending_pulses & self.names)
        self.pending_pulses = set()
        # The later ticks repeat that state without pulses, which only tells the
        # monitor that time has passed: the last of them says it for all (a gap of
        # years between two stamps costs one step, not a step per tick).
        last = self.next_tick + (bound - 1 - self.next_tick) // self.period * self.period
        if last > self.next_tick and self.monitor is not None:
            self.monitor.step(last, state, frozenset())
        self.next_tick = last + self.period

    def advance(self, bound: int) -> None:
        """Nothing changed before `bound`: the monitor knows its input up to there
        (a rate's ticks say it for a sampled property)."""
        if self.period is None and self.monitor is not None and bound > self.start:
            self.monitor.advance(bound)

    def verdicts(self) -> list[tuple]:
        if self.monitor is not None:
            self.segments.extend(map(_in_seconds, self.monitor.verdicts()))
        out, self.segments = self.segments, []
        return out

    def end(self, time: int) -> None:
        self.ticks_before(time + 1)
        self._close(time)


def _in_seconds(segment: tuple) -> tuple:
    """A verdict segment of the monitor (times in nanoseconds) in seconds."""
    return (seconds(segment[0]), seconds(segment[1]), *segment[2:])
