"""`rmv replay`: a resolved spec run over recorded rosbags (docs/replay.md).

Reads ROS 1 `.bag` and ROS 2 `.db3`/`.mcap` recordings through rosbags' AnyReader,
with the recording's own message definitions; checks each topic the spec reads
against them before the first message; feeds the runtime in recording order; and
hands its records to the caller as they are decided.
"""

from __future__ import annotations

import struct
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
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
from rmvdsl.runtime.wording import counted, os_words
from rmvdsl.tools.report.text import decimal_text, text_line
from rmvdsl.tools.typestores import default_store, shared_store


@dataclass
class Position:
    """How far a run has read: the messages the reader gave on the topics the spec
    reads (damaged ones too), and those fed to the runtime."""

    read: int = 0
    fed: int = 0


# A chunk's hook at a seam: (seam, runtime, the graph's endpoints seen, the position)
# -> whether the run stops there.
AtSeam = Callable[[int, Runtime, set[Endpoint], Position], bool]


class ReplayError(Exception):
    """A recording that cannot be read at all (the CLI exits 2)."""


@dataclass
class Plan:
    """What the recording holds for the spec: the connections to read and what
    was found wrong before reading."""

    connections: list[Any] = field(default_factory=list)
    problems: list[tuple[str, str]] = field(default_factory=list)  # (origin, text)
    skipped_variables: set[str] = field(default_factory=set)
    skipped_messages: dict[str, int] = field(default_factory=dict)  # counter -> count


def _path_problem(store: Any, msgtype: str, variable: ir.Variable) -> str | None:
    """Whether the recording's definition of `msgtype` has the variable's path."""
    from rosbags.typesys.base import Nodetype

    current: Any = (Nodetype.NAME, msgtype)
    where = msgtype
    for step in variable.path:
        kind, detail = current
        if isinstance(step, ir.FieldStep):
            if kind != Nodetype.NAME:
                return f"`{where}` is not a message, so it has no field `{step.name}`"
            fields = dict(store.fielddefs[detail][1])
            if step.read not in fields:
                return f"{detail} has no field `{step.read}` (it has {', '.join(fields)})"
            current, where = fields[step.read], f"{where}.{step.read}"
        else:
            if kind not in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                return f"`{where}` is not an array"
            current = detail[0]
    return None


def plan(spec: ir.Spec, reader: Any) -> Plan:
    """Match the spec's topics with the recording's connections."""
    found = Plan()
    by_topic: dict[str, list[Any]] = {}
    for connection in reader.connections:
        by_topic.setdefault(connection.topic, []).append(connection)
    variables: dict[str, list[ir.Variable]] = {}
    for variable in spec.variables:
        variables.setdefault(variable.topic, []).append(variable)
    for topic in spec.topics:
        connections = by_topic.get(topic.ros_name, [])
        if not connections:
            found.problems.append((
                topic.origin,
                f"topic `{topic.name}` ({topic.ros_name}) is not in the recording: "
                "what it feeds stays without values",
            ))  # fmt: skip
            continue
        for connection in connections:
            if connection.msgtype != topic.message_type:
                found.problems.append((
                    topic.origin,
                    f"topic `{topic.name}` ({topic.ros_name}) is recorded as {connection.msgtype}, "
                    f"the spec reads {topic.message_type}: its messages are skipped",
                ))  # fmt: skip
                key = f"messages of another type: {topic.ros_name}"
                skipped = found.skipped_messages
                skipped[key] = skipped.get(key, 0) + connection.msgcount
                continue
            found.connections.append(connection)
            for variable in variables.get(topic.name, []):
                problem = _path_problem(reader.typestore, connection.msgtype, variable)
                if problem is not None and variable.name not in found.skipped_variables:
                    found.skipped_variables.add(variable.name)
                    text = f"variable `{variable.name}` on {topic.ros_name}: {problem}"
                    found.problems.append((variable.origin, text))
    return found


def open_reader(paths: Sequence[Path], spec: ir.Spec) -> Any:
    from rosbags.highlevel import AnyReader, AnyReaderError

    for path in paths:
        if not path.exists():
            raise ReplayError(f"{path}: no such file or directory")
    try:
        reader = AnyReader(list(paths), default_typestore=default_store(spec))
        reader.open()
    except AnyReaderError as error:
        raise ReplayError(
            f"{', '.join(map(str, paths))}: cannot read the recording: {_reader_words(error)}"
        ) from None
    except Exception as error:  # rosbags meets damaged bytes in many ways
        raise ReplayError(
            f"{', '.join(map(str, paths))}: cannot read the recording: {damage(error)}"
        ) from None
    return reader


def _reader_words(error: Exception) -> str:
    """rosbags' refusal, without the Python beneath it."""
    text = str(error)
    if text.startswith("Invalid bag metadata"):
        return "its metadata.yaml is damaged, or not a rosbag2 recording's"
    if text.startswith("Unrecognized storage format"):
        return "it is not a recording: rosbags reads ROS 1 .bag, and .db3 and .mcap of rosbag2"
    return text


def damage(error: Exception) -> str:
    """What a reader's error on damaged bytes means, in a user's words."""
    if isinstance(error, UnicodeDecodeError):
        return "it is damaged: it holds bytes that are not text where text belongs"
    if isinstance(error, OverflowError | IndexError | MemoryError | struct.error):
        return "it is damaged: a length or an offset in it points outside the file"
    if isinstance(error, OSError):
        return os_words(error)
    return str(error) or f"it is damaged ({type(error).__name__})"


def _messages(reader: Any, runtime: Runtime, **window: Any) -> Iterator[tuple[Any, int, bytes]]:
    """The reader's messages, up to where the recording cannot be read any further
    (damaged bytes): said there, and the run ends with what was read."""
    messages = reader.messages(**window)
    last = reader.start_time
    while True:
        try:
            connection, timestamp, raw = next(messages)
        except StopIteration:
            return
        except Exception as error:  # rosbags meets damaged bytes in many ways
            runtime.note(last, f"the recording cannot be read past {decimal_text(seconds(last))}: "
                               f"{damage(error)}; the rest of it is not checked")  # fmt: skip
            return
        last = timestamp
        yield connection, timestamp, raw


def key(connection: Any) -> tuple[int, int]:
    """A connection among several recordings': each numbers its own from 0."""
    return connection.id, id(connection.owner)


def decoder(reader: Any, needs: dict[str, partial_decoding.Needs]) -> Callable[[Any, bytes], Any]:
    """How a connection's messages are decoded: only the fields the spec reads of
    its topic (`needs`, rmvdsl.host.partial_decoding), by a reader compiled from
    the recording's definitions. ROS 1: by the live ROS 1 node's decoder
    (rmvdsl.host.ros1_decoding), from the connection's own definition and md5sum,
    so a bag and a live system are read alike, and two bags holding two versions
    of a type each with its own; ROS 2: from the reader's type store."""
    if reader.is2:
        return _ros2_decoder(shared_store(reader.typestore), needs)
    from rmvdsl.host.ros1_decoding import Decoder

    ros1 = Decoder()
    headers: dict[tuple[int, int], dict[str, str]] = {}

    def decode(connection: Any, raw: bytes) -> Any:
        header = headers.get(key(connection))
        if header is None:
            header = headers[key(connection)] = {
                "type": connection.msgtype, "md5sum": connection.digest,
                "message_definition": connection.msgdef.data,
            }  # fmt: skip
        return ros1.decode(header, raw, needs.get(connection.topic))

    return decode


def _ros2_decoder(
    store: Any, needs: dict[str, partial_decoding.Needs]
) -> Callable[[Any, bytes], Any]:
    readers: dict[tuple[str, str], partial_decoding.Reader] = {}
    fields_of = lambda type_name: store.fielddefs[type_name][1]  # noqa: E731

    def made(topic: str, msgtype: str) -> partial_decoding.Reader:
        def full(raw: bytes | memoryview) -> Any:
            return store.deserialize_cdr(raw, msgtype)

        wanted = [needs[topic]] if topic in needs else []
        return partial_decoding.or_full(full, msgtype, wanted, fields_of, ros1=False)

    def decode(connection: Any, raw: bytes) -> Any:
        which = (connection.topic, connection.msgtype)
        read = readers.get(which)
        if read is None:
            read = readers[which] = made(*which)
        return read(raw)

    return decode


def window_time(text: str | None, start: int) -> int | None:
    """`--from`/`--to`: seconds on the recording's clock, or `+N` after its start."""
    if text is None:
        return None
    from fractions import Fraction

    relative = text.startswith("+")
    value = Fraction(text[1:] if relative else text)
    ns = int(value * 1_000_000_000)
    return start + ns if relative else ns


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
) -> Iterator[Record]:
    """Every record of the spec over the recordings, as it is decided.

    A chunk of a long recording (rmvdsl.tools.fleet.sections) starts reading at
    `read_from` (ns, the recording's clock) and names `seams`: before the first
    message at or after each, everything the input decides is given out and
    `at_seam(seam, runtime, endpoints, position)` runs; when it returns True the
    run stops there, without ending the input. A run that reaches the end fills
    `ended`: where the input ended, the messages the recording lists on the topics
    read, and those read."""
    reader = open_reader(paths, spec)
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
        seen_connections: set[tuple[int, int]] = set()
        read = {key(c) for c in found.connections}
        # ROS 1 bags name each connection's publisher: every connection then
        # counts for intrusion detection, from its first message on.
        publishers = [c for c in reader.connections if getattr(c.ext, "callerid", None)]
        watched = publishers if can_refuse(spec) else []
        connections = found.connections + [c for c in watched if key(c) not in read]
        total = sum(c.msgcount for c in found.connections)
        decode = decoder(reader, partial_decoding.spec_needs(spec, found.skipped_variables))
        position = Position()
        for connection, timestamp, raw in _messages(
            reader, runtime, connections=connections, start=low, stop=high
        ):
            while upcoming and timestamp >= upcoming[0]:
                runtime.decide()
                yield from runtime.records()
                assert at_seam is not None
                if at_seam(upcoming.pop(0), runtime, endpoints, position):
                    return
            if key(connection) not in seen_connections:
                seen_connections.add(key(connection))
                caller = getattr(connection.ext, "callerid", None)
                if caller:
                    endpoints.add(Endpoint(caller, connection.topic, "publisher"))
                    runtime.graph(timestamp, endpoints)
            if key(connection) not in read:
                continue
            position.read += 1
            try:
                message = decode(connection, raw)
            except Exception as error:
                runtime.damaged(timestamp, connection.topic, str(error))
                continue
            runtime.message(timestamp, connection.topic, message)
            position.fed += 1
            if progress is not None and position.fed % 2000 == 0:
                progress(position.fed, total)
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
        out.write(line + "\n")

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
    from rmvdsl.runtime.engine import to_json

    summary = Summary()
    kept: list[Record] = []
    host = ExecutingHost() if run_actions else None
    record = ("state", "event", "variable") if report else ("state", "event")
    records = replay(
        spec, paths, host=host, start=start, stop=stop,
        record=record, progress=progress,
    )  # fmt: skip
    first = True
    repeats = _Repeats()
    if output == "json":
        out.write('{"records": [\n')
    for item in records:
        if item["kind"] == "verdict" and item["verdict"] == "false":
            summary.violations += 1
        elif item["kind"] == "intrusion" and item["phase"] == "start":
            summary.intrusions += 1
        elif item["kind"] == "diagnostic":
            summary.warnings += 1
        elif item["kind"] == "action" and item.get("error"):
            summary.failed_actions += 1
        if report:
            kept.append(item)
        if output == "text":
            repeats.write(item, out)
        elif item["kind"] != "variable":
            separator = "" if first or output == "jsonl" else ",\n"
            out.write(separator + to_json(item) + ("\n" if output == "jsonl" else ""))
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
    if report:
        from rmvdsl.tools import report as reports

        reports.write(report, spec, kept)
    return summary
