"""Fleet replay: one spec over many recordings (docs/fleet.md). The recordings are
found (paths.py), replayed by worker processes on this machine (local.py) or by
the tasks of a Dask cluster (cluster.py), each by worker.py; their results are
printed as they finish, added up (summary.py), and drawn on one page (page.py)."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from rmvdsl.lang.errors import UsageError
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import counted, visible
from rmvdsl.tools.fleet.paths import is_search, recordings
from rmvdsl.tools.fleet.progress import Progress
from rmvdsl.tools.fleet.sections import Job, Joined, plan
from rmvdsl.tools.fleet.summary import FleetSummary
from rmvdsl.tools.fleet.worker import Options as Options
from rmvdsl.tools.fleet.worker import replay_one
from rmvdsl.tools.recordings import ReplayError

SCHEDULER_VARIABLE = "RMV_DASK_SCHEDULER"
INTERRUPTED = 130


@dataclass(frozen=True)
class Settings:
    output: str = "text"  # text | json | jsonl
    jobs: int | None = None  # None: the cores
    scheduler: str | None = None  # a Dask scheduler's address
    report: str | None = None
    quiet: bool = False
    options: Options = field(default_factory=Options)
    chunk: int | None = None  # ns: a longer recording is replayed in chunks


def is_fleet(arguments: list[str], scheduler: str | None, chunk: int | None = None) -> bool:
    """Several recordings, a folder to search or a pattern (or a cluster, or chunks):
    one result per recording. One recording alone keeps its records' output."""
    return (len(arguments) > 1 or scheduler is not None or chunk is not None
            or any(is_search(a) for a in arguments))  # fmt: skip


def scheduler_of(given: str | None, dask: bool) -> str | None:
    """--scheduler, or with --dask the scheduler RMV_DASK_SCHEDULER names."""
    if given is not None:
        return given
    if dask:
        address = os.environ.get(SCHEDULER_VARIABLE)
        if not address:
            raise UsageError(f"--dask: set {SCHEDULER_VARIABLE} to the scheduler's address "
                             "(tcp://HOST:PORT), or give --scheduler")  # fmt: skip
        return address
    return None


def run(spec: ir.Spec, arguments: list[str], out: TextIO, settings: Settings) -> int:
    """Replay every recording; print each result as it comes; the exit code."""
    try:
        found = recordings(arguments)
    except ReplayError as error:
        raise UsageError(str(error)) from None
    # Workers may run elsewhere (another folder, another machine): absolute paths
    # to them, the paths as found in the output.
    shown = [str(p) for p in found]
    paths = [str(p.absolute()) for p in found]
    client = None
    if settings.scheduler is not None:
        from rmvdsl.tools.fleet.cluster import client_for

        client = client_for(settings.scheduler)
    spec_json = ir.dump(spec, indent=None)
    results: list[dict[str, Any] | None] = [None] * len(paths)
    summary = FleetSummary(len(paths))
    stream = None if settings.quiet else sys.stderr
    progress = Progress(stream, len(paths), sys.stderr.isatty())
    printer = _Printer(out, settings.output, progress)

    def recording_done(index: int, result: dict[str, Any]) -> None:
        result["path"] = shown[index]
        results[index] = result
        summary.add(result)
        printer.result(result)
        if "chunks" in result:  # its messages and chunks were counted as they came
            progress.finished(0, units=0)
        else:
            progress.finished(result["messages"])

    work = Work(spec, paths, settings, recording_done, progress)
    interrupted = False
    try:
        if client is not None:
            from rmvdsl.tools.fleet.cluster import run_on_cluster

            with client:
                run_on_cluster(client, spec_json, settings.options, work.jobs, work.done)
        elif _in_process(settings, len(work.jobs)):
            index = 0
            while index < len(work.jobs):  # grows as sections are joined
                work.jobs.extend(work.done(index, replay_one(spec_json, work.jobs[index],
                                                             settings.options)))  # fmt: skip
                index += 1
        else:
            from rmvdsl.tools.fleet.local import LocalPool

            jobs = settings.jobs or os.cpu_count() or 1
            LocalPool(spec_json, jobs, settings.options).run(work.jobs, work.done)
    except KeyboardInterrupt:
        interrupted = True
    finished = [r for r in results if r is not None]
    printer.end(finished, summary, interrupted)
    if settings.report:
        from rmvdsl.tools.fleet.page import page

        Path(settings.report).write_text(page(spec, finished, summary), encoding="utf-8")
    return INTERRUPTED if interrupted else summary.exit_code()


class Work:
    """The jobs: a recording each, or with --chunk the sections of a long one, whose
    results are joined (sections.py) before the recording's result is given."""

    def __init__(self, spec: ir.Spec, paths: list[str], settings: Settings,
                 recording_done: Callable[[int, dict[str, Any]], None],
                 progress: Progress) -> None:  # fmt: skip
        self.progress = progress
        self.jobs: list[Job] = []
        self.owner: list[int] = []  # each job's recording
        self.joins: dict[int, Joined] = {}  # recording -> its sections' join
        self.recording_done = recording_done
        options = settings.options
        for index, path in enumerate(paths):
            sections = [] if settings.chunk is None else plan(
                path, spec, settings.chunk, options.start, options.stop)  # fmt: skip
            if sections:
                windowed = options.start is not None or options.stop is not None
                self.joins[index] = Joined(path, sections, windowed)
            jobs = [Job(path, section) for section in sections] or [Job(path)]
            self.jobs.extend(jobs)
            self.owner.extend(index for _ in jobs)
        progress.units = len(self.jobs)
        progress.chunked = bool(self.joins)

    def done(self, index: int, result: dict[str, Any]) -> list[Job]:
        """A job's result: the recording's when whole; the jobs it makes necessary."""
        recording = self.owner[index]
        join = self.joins.get(recording)
        if join is None:
            self.recording_done(recording, result)
            return []
        if join.result is not None:
            return []  # a section failed and the recording with it: the rest is moot
        first_wave = any(self.jobs[index].section is s for s in join.sections)
        if first_wave and "section" in result:
            messages = result["section"]["section_messages"]
            self.progress.finished(messages, recordings=0)
        more = join.add(self.jobs[index], result)
        self.owner.extend(recording for _ in more)
        if join.result is not None:
            self.recording_done(recording, join.result)
        return more


def _in_process(settings: Settings, count: int) -> bool:
    """One worker and nothing to guard against: no process of its own."""
    return (settings.jobs == 1 or count == 1) and settings.options.timeout is None


class _Printer:
    """Each result as it finishes (text or jsonl), or all at the end (json)."""

    def __init__(self, out: TextIO, output: str, progress: Progress) -> None:
        self.out, self.output, self.progress = out, output, progress

    def result(self, result: dict[str, Any]) -> None:
        if self.output == "json":
            return
        self.progress.clear()
        if self.output == "jsonl":
            self.out.write(as_json(result) + "\n")
        else:
            self.out.write(visible(text_line(result)) + "\n")
        self.out.flush()

    def end(self, results: list[dict[str, Any]], summary: FleetSummary, stopped: bool) -> None:
        if self.output == "json":
            self.out.write('{"recordings": [\n' + ",\n".join(as_json(r) for r in results)
                           + "\n]}\n")  # fmt: skip
        elif self.output == "text":
            if stopped:
                self.out.write("interrupted: ")
            self.out.write(visible("\n".join(summary.lines())) + "\n")
        elif stopped:
            sys.stderr.write(visible("rmv replay: interrupted: " + summary.lines()[0]) + "\n")


def as_json(result: dict[str, Any]) -> str:
    """A recording's object: its path and status, the counts that decided it, and its
    records as `rmv replay --format json` prints them for it alone (exact numbers)."""
    head = {k: v for k, v in result.items() if k not in ("records", "timed_out")}
    return json.dumps(head)[:-1] + ', "records": [' + ", ".join(result["records"]) + "]}"


def text_line(result: dict[str, Any]) -> str:
    status, path = result["status"], result["path"]
    if status in ("unreadable", "failed"):
        return f"{status:<11} {path}: {result.get('error', '')}"
    parts = [counted(result["messages"], "message", grouped=True), f"{result['seconds']:g} s"]
    if result["intrusions"]:
        parts.insert(0, counted(result["intrusions"], "intrusion"))
    if result["violations"]:
        parts.insert(0, counted(result["violations"], "violation"))
    if "chunks" in result:
        read_on = result["seams_read_past"]
        past = f", read on past {counted(read_on, 'seam')}" if read_on else ""
        parts.append(counted(result["chunks"], "chunk") + past)
    return f"{status:<11} {path} ({', '.join(parts)})"
