"""`rmv replay`: a resolved spec run over recorded rosbags (docs/replay.md).

Reads ROS 1 `.bag` and ROS 2 `.db3`/`.mcap` recordings through rosbags' AnyReader,
with the recording's own message definitions; checks each topic the spec reads
against them before the first message; feeds the runtime in recording order; and
hands its records to the caller as they are decided.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rmvdsl.host import partial_decoding
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import (
    Endpoint,
    Host,
    Record,
    RecordingHost,
    Runtime,
    can_refuse,
    seconds,
)
from rmvdsl.runtime.wording import counted, visible
from rmvdsl.tools import read_ahead
from rmvdsl.tools.read_ahead import Damaged
from rmvdsl.tools.recordings import (
    ReplayError,
    connection_readers,
    key,
    open_reader,
    plan,
    window_time,
)
from rmvdsl.tools.report.text import decimal_text, text_line
from rmvdsl.util.batched import Batched, batched


@dataclass
class Position:
    """How far a run has read: the messages the reader gave on the topics the spec
    reads (damaged ones too), and those fed to the runtime."""

    read: int = 0
    fed: int = 0


# A chunk's hook at a seam: (seam, runtime, the graph's endpoints seen, the position)
# -> whether the run stops there.
AtSeam = Callable[[int, Runtime, set[Endpoint], Position], bool]


def replay(
    spec: ir.Spec,
    paths: Sequence[Path],
    *,
    host: Host | None = None,
    start: str | None = None,
    stop: str | None = None,
    record: Sequence[str] = ("state", "event"),
    progress: Callable[[int, int], None] | None = None,
    read_from: int | None = None,
    seams: Sequence[int] = (),
    at_seam: AtSeam | None = None,
    ended: dict[str, int] | None = None,
    in_a_child: bool = False,
) -> Iterator[Record]:
    """Every record of the spec over the recordings, as it is decided.

    A chunk of a long recording (rmvdsl.tools.fleet.sections) starts reading at
    `read_from` (ns, the recording's clock) and names `seams`: before the first
    message at or after each, everything the input decides is given out and
    `at_seam(seam, runtime, endpoints, position)` runs; when it returns True the
    run stops there, without ending the input. A run that reaches the end fills
    `ended`: where the input ended, the messages the recording lists on the topics
    read, and those read. `in_a_child`: the recording is read, decoded and its
    readings taken in a second process (rmvdsl.tools.read_ahead)."""
    reader = open_reader(paths, spec)
    items: Generator[read_ahead.Item, None, None] | None = None
    try:
        found = plan(spec, reader)
        for origin, problem in found.problems:
            yield {
                "kind": "diagnostic", "time": seconds(reader.start_time), "origin": origin,
                "message": problem,
            }  # fmt: skip
        runtime = Runtime(spec, host, record=record, skip=found.skipped_variables)
        runtime.counters.update(found.skipped_messages)
        low, high = window_time(start, reader.start_time), window_time(stop, reader.start_time)
        if low is not None and high is not None and low >= high:
            raise ReplayError(f"--from {start} --to {stop}: the window is empty: "
                              "it ends where it starts or before")  # fmt: skip
        whole = low is None and high is None and read_from is None
        if read_from is not None:
            low = read_from
        upcoming = list(seams)
        endpoints: set[Endpoint] = set()
        read = {key(c) for c in found.connections}
        # ROS 1 bags name each connection's publisher: every connection then
        # counts for intrusion detection, from its first message on.
        publishers = [c for c in reader.connections if getattr(c.ext, "callerid", None)]
        watched = publishers if can_refuse(spec) else []
        connections = found.connections + [c for c in watched if key(c) not in read]
        total = sum(c.msgcount for c in found.connections)
        items = read_ahead.readings(
            reader, connections, read,
            connection_readers(reader, partial_decoding.spec_needs(spec, found.skipped_variables)),
            runtime.readers, low, high,
        )  # fmt: skip
        if in_a_child:
            items = read_ahead.in_a_child(items)
        position = Position()
        # Per connection, by its index: its topic and whether the spec reads it,
        # known from its first message on (None: no message yet).
        known: list[tuple[str, bool] | None] = [None] * len(connections)
        for index, timestamp, reading in items:
            while upcoming and timestamp >= upcoming[0]:
                runtime.decide()
                yield from runtime.records()
                assert at_seam is not None
                if at_seam(upcoming.pop(0), runtime, endpoints, position):
                    return
            if index < 0:  # the recording cannot be read further
                runtime.note(timestamp, reading.text)
                continue  # the last item
            seen = known[index]
            if seen is None:
                connection = connections[index]
                seen = known[index] = (connection.topic, key(connection) in read)
                caller = getattr(connection.ext, "callerid", None)
                if caller:
                    endpoints.add(Endpoint(caller, connection.topic, "publisher"))
                    runtime.graph(timestamp, endpoints)
            topic, is_read = seen
            if not is_read:
                continue
            position.read += 1
            if type(reading) is Damaged:
                runtime.damaged(timestamp, topic, reading.reason)
                continue
            runtime.take(timestamp, topic, reading)
            position.fed += 1
            if progress is not None and position.fed % 2000 == 0:
                progress(position.fed, total)
            if runtime.out:
                yield from runtime.records()
        for seam in upcoming:  # after the last message
            runtime.decide()
            yield from runtime.records()
            assert at_seam is not None
            if at_seam(seam, runtime, endpoints, position):
                return
        # rosbags' end_time is one nanosecond after the newest message.
        end = high if high is not None else reader.end_time - 1
        if whole and position.read != total:
            runtime.unreadable(end, total, position.read)
        elif read_from is None and not whole and position.read == 0:
            runtime.note(end, f"the window {_window(start, stop)} holds no message of the "
                              "topics the spec reads: nothing was checked")  # fmt: skip
        if ended is not None:
            ended.update(end=end, listed=total, read=position.read)
        runtime.end(end)
        if progress is not None:
            progress(position.fed, total)
        yield from runtime.records()
    finally:
        if items is not None:
            items.close()  # the reader's process ends before its recording closes
        reader.close()


def _window(start: str | None, stop: str | None) -> str:
    return " ".join(f"{flag} {value}" for flag, value in (("--from", start), ("--to", stop))
                    if value is not None)  # fmt: skip


def progress_bar(stream: Any = sys.stderr) -> Callable[[int, int], None]:
    """A one-line progress bar, redrawn in place."""

    def draw(done: int, total: int) -> None:
        fraction = done / total if total else 1.0
        filled = int(fraction * 30)
        messages = counted(total, "message", grouped=True)
        stream.write(f"\r[{'#' * filled}{'.' * (30 - filled)}] {done:,}/{messages}")
        if done >= total:
            stream.write("\n")
        stream.flush()

    return draw


# ---- output ----


@dataclass
class Summary:
    violations: int = 0
    intrusions: int = 0
    warnings: int = 0  # the recording did not match the spec: some input was lost
    failed_actions: int = 0  # --run-actions: an action that did not do its job

    @property
    def failed(self) -> bool:
        return bool(self.violations or self.intrusions)


class _Repeats:
    """Text output for a person: an action repeated with nothing else between
    (an alert's post at every point at its level) is one line and a count."""

    def __init__(self) -> None:
        self.key: tuple[Any, ...] | None = None
        self.count = 0
        self.last: Any = None

    def write(self, record: Record, out: Any) -> None:
        line = text_line(record)
        if line is None:
            return
        key = None
        if record["kind"] == "action":
            key = tuple(v for k, v in record.items() if k != "time")
            if key == self.key:
                self.count += 1
                self.last = record["time"]
                return
        self.flush(out)
        self.key = key
        out.write(visible(line) + "\n")  # names from the recording are anyone's

    def flush(self, out: Any) -> None:
        if self.count:
            out.write(f"          (and {self.count} more, until {decimal_text(self.last)})\n")
        self.key, self.count = None, 0


class ExecutingHost(RecordingHost):
    """`--run-actions`: exec, post and tcp really run (exec with no shell, the
    record as JSON on standard input); log and publish stay records."""

    def act(self, action: ir.Action, context: Any) -> None:
        from rmvdsl.runtime.actions import leaves_the_process, perform
        from rmvdsl.runtime.engine import action_record

        record = action_record(action, context)
        if leaves_the_process(action):
            error = perform(action, context.record)
            if error is not None:
                record["error"] = error
        record["ran"] = leaves_the_process(action)
        self.records.append(record)


def run(
    spec: ir.Spec,
    paths: Sequence[Path],
    out: Any,
    *,
    output: str = "text",
    start: str | None = None,
    stop: str | None = None,
    report: str | None = None,
    run_actions: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> Summary:
    """Replay and print; return what decides the exit code."""
    summary = Summary()
    kept: list[Record] = []
    host = ExecutingHost() if run_actions else None
    record: tuple[str, ...] = ("state", "event")
    if report:
        record = ("state", "event", "variable")
    elif output == "text":
        record = ("state",)  # text shows no value of an event (report.text.text_line)
    records = replay(
        spec, paths, host=host, start=start, stop=stop,
        record=record, progress=progress, in_a_child=read_ahead.usable(),
    )  # fmt: skip
    with batched(out) as lines:
        _write(records, lines, output, summary, kept if report else None)
    if report:
        from rmvdsl.tools import report as reports

        reports.write(report, spec, kept)
    return summary


def _write(
    records: Iterator[Record],
    out: Batched,
    output: str,
    summary: Summary,
    kept: list[Record] | None,
) -> None:
    """The records in `output`'s form, counted in `summary`, and kept in `kept`
    for a report."""
    from rmvdsl.runtime.engine import to_json

    first = True
    repeats = _Repeats()
    if output == "json":
        out.write('{"records": [\n')
    lines = output == "jsonl"
    for item in records:
        kind = item["kind"]
        if kind in _COUNTED:
            _count(item, kind, summary)
        if kept is not None:
            kept.append(item)
        if output == "text":
            repeats.write(item, out)
        elif kind == "variable":
            continue
        elif lines:
            out.write(to_json(item) + "\n")
        else:
            out.write(to_json(item) if first else ",\n" + to_json(item))
            first = False
    if output == "json":
        out.write("\n]}\n")
    if output == "text":
        repeats.flush(out)
        verdict = "FAILED" if summary.failed else "incomplete" if summary.warnings else "passed"
        out.write(
            f"{verdict}: {counted(summary.violations, 'violation')}, "
            f"{counted(summary.intrusions, 'intrusion')}"
            + (
                f", {counted(summary.warnings, 'warning')} about the recording"
                if summary.warnings
                else ""
            )
            + (
                f", {counted(summary.failed_actions, 'action')} failed"
                if summary.failed_actions
                else ""
            )
            + "\n"
        )


_COUNTED = frozenset(("verdict", "intrusion", "diagnostic", "action"))  # kinds `_count` reads


def _count(item: Record, kind: str, summary: Summary) -> None:
    """What a record of those kinds adds to the summary the exit code comes from."""
    if kind == "verdict" and item["verdict"] == "false":
        summary.violations += 1
    elif kind == "intrusion" and item["phase"] == "start":
        summary.intrusions += 1
    elif kind == "diagnostic":
        summary.warnings += 1
    elif kind == "action" and item.get("error"):
        summary.failed_actions += 1
