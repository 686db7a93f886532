"""The collector's work (the kapacitor target's node, the thesis's rostopicmon),
with no ROS in it: every message's variables become one point of line protocol,
and the states the runtime's transducers enter become points too; points wait in
a bounded buffer and a thread of their own writes them to InfluxDB in batches.

When InfluxDB is slow or down, a batch is retried with back-off and the buffer
fills; past its bound the oldest points are dropped. Everything dropped is counted
and logged, never silent. Credentials come from the environment only."""

from __future__ import annotations

import base64
import collections
import dataclasses
import os
import re
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Protocol

from rmvdsl.host.gaps import Gaps, Undecodable
from rmvdsl.host.spool import Spool
from rmvdsl.host.status import OK, WARN, Status, percentiles
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Runtime
from rmvdsl.runtime.lineproto import PointWriter, state_point
from rmvdsl.runtime.wording import counted

NODE_NAME = "rmv_collector"
RETRY_FIRST, RETRY_LAST = 0.5, 30.0  # seconds between tries of a failed batch
DELAY_SAMPLES = 1_000


class Refused(Exception):
    """InfluxDB answered the batch with an error no retry can mend (HTTP 4xx)."""


class Logs(Protocol):
    def log(self, level: str, text: str) -> None: ...


@dataclass(frozen=True)
class Settings:
    """Where and how the points are written (the spec's `database`, then the
    node's parameters)."""

    url: str
    database: str
    retention_policy: str
    batch_size: int
    flush_interval: float  # seconds
    timeout: float  # seconds
    buffer: int  # points at most waiting in memory
    username_env: str
    password_env: str
    spool: str = ""  # a file for the points past `buffer` ("": none)
    spool_bytes: int = 0  # the spool file's bound

    @property
    def write_url(self) -> str:
        query = urllib.parse.urlencode(
            {"db": self.database, "rp": self.retention_policy, "precision": "n"}
        )
        return f"{self.url.rstrip('/')}/write?{query}"


def settings(database: ir.Database, parameter: Callable[[str, Any], Any]) -> Settings:
    """The settings from the spec's `database` block, each overridden by the node's
    parameter of the same name (`parameter(name, default)` reads one)."""
    return Settings(
        url=str(parameter("influx_url", database.url)),
        database=str(parameter("database", database.name)),
        retention_policy=str(parameter("retention_policy", database.default_retention)),
        batch_size=int(parameter("batch_size", database.batch_size)),
        flush_interval=float(parameter("flush_interval", float(database.flush_interval))),
        timeout=float(parameter("timeout", float(database.timeout))),
        buffer=int(parameter("buffer", 100_000)),
        username_env=_env(database.username, "INFLUX_USERNAME"),
        password_env=_env(database.password, "INFLUX_PASSWORD"),
        spool=str(parameter("spool", "")),
        spool_bytes=int(parameter("spool_bytes", 1_000_000_000)),
    )


def _env(credential: ir.Credential | None, default: str) -> str:
    """The environment variable holding a credential (the spec's, else `default`)."""
    return credential.env if credential is not None and credential.env else default


class Collector:
    def __init__(
        self, spec: ir.Spec, settings: Settings, logs: Logs, clock: Callable[[], int]
    ) -> None:
        self.spec = spec
        self.settings = settings
        self.logs = logs
        self.clock = clock
        self.batch_size = max(1, settings.batch_size)
        self.bound = max(self.batch_size, settings.buffer)
        self.writer = PointWriter(spec)
        # events and transducers only: properties and alerts are the monitor's
        self.runtime = Runtime(
            dataclasses.replace(spec, properties=(), alerts=()), record=("state",)
        )
        self.gaps = Gaps()
        self.received = 0  # the newest receipt time given
        self.lock = threading.Condition()
        self.waiting: collections.deque[tuple[str, int]] = collections.deque()  # line, arrival
        self.in_flight = 0  # points of the batch being written
        self.counters: collections.Counter[str] = collections.Counter()
        self.delays: collections.deque[int] = collections.deque(maxlen=DELAY_SAMPLES)
        self.reported: set[str] = set()
        self.state = "writing"
        self.stopping = False
        self.spool = Spool(settings.spool, settings.spool_bytes) if settings.spool else None
        self.thread = threading.Thread(target=self.write_batches, name="rmv-influx", daemon=True)

    def start(self) -> None:
        self.thread.start()

    # ---- in: the executor's thread ----

    def take(self, topic: str, message: Any, info: dict[str, Any]) -> None:
        lost = self.gaps.lost(topic, info)
        if lost < 0:  # counted lost, then came out of order
            self.count(f"lost messages: {topic}", lost, "")
            self.count(f"messages out of order: {topic}", 1,
                       f"{topic}: a message came after a later one")  # fmt: skip
        elif lost:
            self.count(f"lost messages: {topic}", lost,
                       f"{topic}: {counted(lost, 'message')} lost before the collector "
                       f"read {'it' if lost == 1 else 'them'}")  # fmt: skip
        if "unread" in info:  # variables its publisher's definition does not give
            self.skip(topic, info["unread"])
        if isinstance(message, Undecodable):
            self.count(f"damaged messages: {topic}", 1, f"{topic}: {message.reason}")
            return
        self.counters["messages"] += 1
        arrival = info.get("received_timestamp") or time.time_ns()
        # Receipt times strictly increase: two messages of a topic at one time would
        # be one point in InfluxDB (the later overwrites the earlier).
        self.received = max(self.clock(), self.received + 1)
        point = self.writer.point(self.received, topic, message)
        for cause, count in self.writer.dropped.items():
            self.count(cause, count, f"{cause}: not stored")
        self.writer.dropped.clear()
        self.runtime.message(self.received, topic, message)
        lines = [] if point is None else [point[1]]
        lines += self.states()
        for line in lines:
            self.enqueue(line, arrival)

    def skip(self, topic: str, unread: dict[str, str]) -> None:
        """Variables no longer read nor stored, each warned of once (the runtime's
        records but states are not the collector's to say)."""
        self.writer.skip(topic, unread)
        self.runtime.skip(self.received, topic, unread)
        for name, text in unread.items():
            with self.lock:
                first = f"unread: {name}" not in self.reported
                self.reported.add(f"unread: {name}")
            if first:
                self.logs.log("warn", text)

    def states(self) -> list[str]:
        """The states the runtime has decided since the last call, as points."""
        return [
            state_point(self.spec, r["transducer"], r["state"], _ns(r["time"]))
            for r in self.runtime.records()
            if r["kind"] == "state"
        ]

    def enqueue(self, line: str, arrival: int) -> None:
        with self.lock:
            if len(self.waiting) + self.in_flight >= self.bound:
                if not self.waiting:  # the whole bound is being written
                    self._overflow_unlocked((line, arrival))
                    return
                # The oldest leave memory (the newest matter most): to the spool, if
                # there is one with room, else dropped.
                self._overflow_unlocked(self.waiting.popleft())
            self.waiting.append((line, arrival))
            if len(self.waiting) >= self.batch_size:
                self.lock.notify()

    def _overflow_unlocked(self, point: tuple[str, int]) -> None:
        if self.spool is not None and self.spool.push(*point):
            return
        self.counters["points dropped: buffer full"] += 1
        if "buffer" not in self.reported:
            self.reported.add("buffer")
            where = counted(self.bound, "point")
            if self.spool is not None:
                where += f" in memory and {counted(self.spool.bound, 'byte')} on disk"
            self.logs.log(
                "error",
                f"InfluxDB cannot keep up: {where} wait; the oldest are dropped and counted "
                "(`points dropped: buffer full`)",
            )

    def count(self, counter: str, number: int, text: str) -> None:
        with self.lock:
            self.counters[counter] += number
            first = counter not in self.reported
            self.reported.add(counter)
        if first:
            self.logs.log("warn", text)

    # ---- out: the writer's thread ----

    def write_batches(self) -> None:
        while True:
            with self.lock:
                self.lock.wait_for(
                    lambda: self.stopping or len(self.waiting) >= self.batch_size,
                    timeout=self.settings.flush_interval,
                )
                if self.stopping and not self.waiting:
                    return
                size = min(self.batch_size, len(self.waiting))
                batch = [self.waiting.popleft() for _ in range(size)]
                if len(batch) < self.batch_size and self.spool is not None and self.spool.count:
                    batch += self.spool.take(self.batch_size - len(batch))
                self.in_flight = len(batch)
            if batch:
                self.deliver(batch)
            with self.lock:
                self.in_flight = 0

    def deliver(self, batch: list[tuple[str, int]]) -> None:
        """Write one batch, retrying with back-off until InfluxDB takes or refuses it."""
        body = ("\n".join(line for line, _ in batch) + "\n").encode()
        pause = RETRY_FIRST
        while True:
            try:
                self.post(body)
            except Refused as refused:
                dropped = re.search(r"dropped=(\d+)", str(refused))
                number = int(dropped.group(1)) if dropped else len(batch)
                text = f"InfluxDB refused points: {refused}"
                self.count("points refused by InfluxDB", number, text)
                self.counters["points written"] += len(batch) - number
                return
            except OSError as error:  # unreachable, timed out, or a 5xx
                self.state = f"retrying: {getattr(error, 'reason', error)}"
                if self.stopping:
                    self._at_exit(batch, error)
                    return
                time.sleep(pause)
                pause = min(pause * 2, RETRY_LAST)
                continue
            now = time.time_ns()
            with self.lock:
                self.counters["points written"] += len(batch)
                self.delays.extend(now - arrival for _, arrival in batch)
            self.state = "writing"
            return

    def _at_exit(self, batch: list[tuple[str, int]], error: OSError) -> None:
        """InfluxDB is down as the node stops: the batch goes to the spool (the next
        run writes it), what does not fit is dropped and counted."""
        with self.lock:
            left = [p for p in batch if self.spool is None or not self.spool.push(*p)]
        if left:
            self.count("points dropped: InfluxDB down at exit", len(left),
                       f"{counted(len(left), 'point')} not written at exit: {error}")  # fmt: skip

    def post(self, body: bytes) -> None:
        request = urllib.request.Request(self.settings.write_url, data=body, method="POST")
        username = os.environ.get(self.settings.username_env)
        if username:
            password = os.environ.get(self.settings.password_env, "")
            token = f"{username}:{password}".encode()
            request.add_header("Authorization", "Basic " + base64.b64encode(token).decode())
        try:
            with urllib.request.urlopen(request, timeout=self.settings.timeout):
                return
        except urllib.error.HTTPError as error:
            text = error.read().decode(errors="replace")[:500]
            if 400 <= error.code < 500:
                raise Refused(f"HTTP {error.code}: {text}") from None
            raise OSError(f"HTTP {error.code}: {text}") from None

    # ---- every diagnostics period ----

    def tick(self) -> Status:
        """States that time alone decides (the runtime otherwise decides in batches
        of messages), then the status."""
        self.runtime.decide()
        for line in self.states():
            self.enqueue(line, time.time_ns())
        return self.status()

    def status(self) -> Status:
        with self.lock:
            values = {k: str(v) for k, v in sorted(self.counters.items())}
            values["points waiting"] = str(len(self.waiting) + self.in_flight)
            if self.spool is not None:
                values["points spooled"] = str(len(self.spool))
            values.update(percentiles("storage delay", list(self.delays)))
        dropped = any(k.startswith(("points dropped", "points refused")) for k in values)
        level = WARN if self.state != "writing" or dropped else OK
        return Status(NODE_NAME, "influxdb", level, self.state, values)

    def finish(self) -> Status:
        """Write what waits (one try each) before the process ends, the states the
        end of the input decides included; the last status."""
        self.runtime.end()
        for line in self.states():
            self.enqueue(line, time.time_ns())
        with self.lock:
            self.stopping = True
            self.lock.notify()
        if self.thread.is_alive():
            self.thread.join(timeout=self.settings.timeout * 4 + 5)
        final = self.status()
        if self.spool is not None:
            with self.lock:
                self.spool.close()  # what it holds is written by the next run
        return final


def _ns(seconds: Any) -> int:
    """A record's time (exact seconds) in integer nanoseconds."""
    return int(Fraction(seconds) * 1_000_000_000)
