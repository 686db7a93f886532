"""The monitor node's work, with no ROS in it: ROS's executor hands each message to
`take`, which gives it a receipt time and queues it; one worker thread owns the
runtime — it feeds the messages (in the order of the times they take), decides,
and hands verdict segments, statuses and warnings to the node's `Outputs`. A long
run of the runtime (a minute's continuous queries) then never keeps the readers
from being read."""

from __future__ import annotations

import collections
import math
import queue
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

from rmvdsl.host.gaps import Gaps, Undecodable
from rmvdsl.host.status import (
    ALERT_LEVELS,
    OK,
    STALE,
    VERDICT_LEVELS,
    Status,
    percentiles,
    verdict_segment,
)
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Host, Runtime, to_json

NODE_NAME = "rmv_monitor"
# A message taken by the executor: receipt time, topic, message, message info.
Item = tuple[int, str, Any, dict[str, Any]]
# At most this many taken messages are put in time order and fed at once.
BATCH = 1000
# How many of the latest arrival-to-verdict latencies the diagnostics summarise.
LATENCY_SAMPLES = 1_000


def in_time_order(batch: list[Item], time_of: Callable[[int, str, Any], int | None]) -> list[Item]:
    """The batch sorted by the times its messages take (ties by receipt); a message
    that takes none stays just after the one it came after (first, if it came
    first): the runtime reads it as unknown input from the topic's last message, so
    where it stands must not depend on what else the executor took with it (an
    ahead-stamped message sorted last in its batch made the stretch unknown from
    whichever message came last)."""
    keys: list[tuple[float, int]] = []
    previous: tuple[float, int] = (-math.inf, 0)
    for received, topic, message, *_ in batch:
        taken = time_of(received, topic, message)
        previous = previous if taken is None else (taken, received)
        keys.append(previous)
    order = sorted(range(len(batch)), key=keys.__getitem__)
    return [batch[i] for i in order]


class Outputs(Protocol):
    """What the node publishes and logs."""

    def verdict(self, text: str) -> None: ...

    def statuses(self, statuses: list[Status]) -> None: ...

    def warn(self, text: str) -> None: ...


class Monitor:
    """`clock()`: the node's time in integer nanoseconds (simulated under
    use_sim_time). `decide_period`, `diagnostics_period`: seconds."""

    def __init__(
        self, spec: ir.Spec, actions: Host, out: Outputs, clock: Callable[[], int],
        decide_period: float = 0.1, diagnostics_period: float = 1.0,
        queue_depth: int = 100_000, ros_version: int = 2,
    ) -> None:  # fmt: skip
        self.spec = spec
        self.out = out
        self.clock = clock
        self.decide_period = decide_period
        self.diagnostics_period = diagnostics_period
        self.runtime = Runtime(spec, actions, record=("state",), ros_version=ros_version)
        self.current: dict[str, str] = {p.name: "unknown" for p in spec.properties}
        self.levels: dict[str, str] = {a.name: "OK" for a in spec.alerts}
        self.gaps = Gaps()
        self.latencies: collections.deque[int] = collections.deque(maxlen=LATENCY_SAMPLES)
        # Shared by the two threads, under `self.taking`: the newest receipt time
        # given, and how many taken messages the worker has not fed yet.
        self.taking = threading.Lock()
        self.received = 0
        self.unfed = 0
        self.unfed_peak = 0  # the most taken and not yet fed at once: the queue's use
        self.queue_depth = max(queue_depth, 1)
        self.fed = 0  # the worker's: the receipt time of the newest message fed
        self.inbox: queue.Queue[Item | None] = queue.Queue(maxsize=self.queue_depth)
        self.worker = threading.Thread(target=self.work, name="rmv-runtime", daemon=True)

    def start(self) -> None:
        self.worker.start()

    def take(self, topic: str, message: Any, info: dict[str, Any]) -> None:
        """The executor's callback: a receipt time, then the worker's queue. Receipt
        times strictly increase (two callbacks may read the same clock value, and
        the system clock may step back): the runtime may then treat everything up
        to a message's time as final. A full queue blocks the executor, so the
        readers overflow and the sequence numbers count what they lose."""
        with self.taking:
            now = self.received = max(self.clock(), self.received + 1)
            self.unfed += 1
            self.unfed_peak = max(self.unfed_peak, self.unfed)
        self.inbox.put((now, topic, message, info))

    def work(self) -> None:
        """The worker: feed messages as they come, decide when the queue runs dry
        (the node keeps up: lowest latency) or every `decide_period` (it is behind:
        the runtime batches), report the statuses every `diagnostics_period`."""
        next_decide = time.monotonic() + self.decide_period
        next_report = time.monotonic() + self.diagnostics_period
        while True:
            wait = max(0.0, min(next_decide, next_report) - time.monotonic())
            try:
                batch, stopping = self.waiting(self.inbox.get(timeout=wait))
            except queue.Empty:
                batch, stopping = [], False
            for item in batch:
                self.feed(*item)
            if stopping:
                return
            if batch and self.inbox.empty():
                self.decide(batch[-1][3].get("received_timestamp"))
            now = time.monotonic()
            if now >= next_decide:
                self.decide(None)
                next_decide = now + self.decide_period
            if now >= next_report:
                self.report()
                next_report = now + self.diagnostics_period

    def waiting(self, first: Item | None) -> tuple[list[Item], bool]:
        """`first` and what else the executor has taken meanwhile, in the order of
        the times the messages take: topics stamped by their headers, taken in the
        executor's order of readers, are fed in the order of their stamps (a
        stamp older than one fed before is late); and whether the node is stopping
        (what was taken before it stopped is fed all the same)."""
        batch: list[Item] = []
        item = first
        while item is not None:
            batch.append(item)
            if len(batch) == BATCH:
                break
            try:
                item = self.inbox.get_nowait()
            except queue.Empty:
                break
        return in_time_order(batch, self.runtime.time_of), item is None

    def feed(self, now: int, topic: str, message: Any, info: dict[str, Any]) -> None:
        lost = self.gaps.lost(topic, info)
        if lost > 0:
            self.runtime.lost(now, topic, lost)
        elif lost < 0:
            self.runtime.found_again(now, topic)
        if "unread" in info:  # variables its publisher's definition does not give
            self.runtime.skip(now, topic, info["unread"])
        if isinstance(message, Undecodable):
            self.runtime.damaged(now, topic, message.reason)
        else:
            self.runtime.message(now, topic, message)
        self.fed = now
        with self.taking:
            self.unfed -= 1

    def decide(self, arrived: int | None) -> None:
        """Decide what the input so far decides; `arrived` is the system time at
        which the message just fed reached the node, for the latency figures."""
        self.runtime.decide(complete_before=self.received_bound())
        if self.publish_records() and arrived:
            self.latencies.append(time.time_ns() - arrived)

    def received_bound(self) -> int:
        """No message fed from now on can have a receipt time before this: the clock
        when every message taken has been fed, else the newest fed. (Not past it: a
        simulated clock stands still, and the next message may share its time.)"""
        with self.taking:
            if self.unfed:
                return self.fed
            return max(self.clock(), self.received)

    def publish_records(self) -> int:
        """Hand out what the runtime decided; the number of verdict segments."""
        segments = 0
        for record in self.runtime.records():
            if record["kind"] == "verdict":
                segments += 1
                self.current[record["property"]] = record["verdict"]
                self.out.verdict(to_json(verdict_segment(record)))
            elif record["kind"] == "alert":
                self.levels[record["alert"]] = record["level"]
            elif record["kind"] == "diagnostic":
                self.out.warn(f"{record['origin']}: {record['message']}")
        return segments

    def statuses(self) -> list[Status]:
        """One status per property (its open segment's verdict, else its last), per
        alert, and the runtime's counters."""
        pending = {n: s[4] for n, s in self.runtime.pending_segments.items()}
        found = []
        for prop in self.spec.properties:
            verdict = pending.get(prop.name, self.current[prop.name])
            level = VERDICT_LEVELS.get(verdict, STALE)
            found.append(
                Status(NODE_NAME, f"property {prop.name}", level, verdict, {"formula": prop.text})
            )
        for alert in self.spec.alerts:
            level = self.levels[alert.name]
            found.append(Status(NODE_NAME, f"alert {alert.name}", ALERT_LEVELS[level], level))
        counters = {k: str(v) for k, v in sorted(self.runtime.counters.items())}
        counters.update(percentiles("verdict latency", self.latencies))
        # read and not yet fed: the queue's `queue_depth` and the batch being fed
        counters["messages held, most"] = f"{self.unfed_peak} of {self.queue_depth + BATCH}"
        found.append(Status(NODE_NAME, "monitor", OK, "running", counters))
        return found

    def report(self) -> None:
        self.out.statuses(self.statuses())

    def finish(self) -> None:
        """The input is over: feed what was taken, decide everything, hand out the
        last segments and the final statuses."""
        self.inbox.put(None)
        if self.worker.is_alive():
            self.worker.join()
        self.runtime.end()
        self.publish_records()
        self.report()
