"""One recording replayed, as a worker does it (in a process of --jobs, or a task on
a Dask worker): the spec arrives once as its resolved IR's JSON, each recording
gives one result, a plain dict that crosses processes and machines."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.tools import replay
from rmvdsl.tools.fleet.sections import Job, replay_section, status_of, tally
from rmvdsl.tools.recordings import ReplayError
from rmvdsl.util import collection

# What a result's `status` says, from worst to best.
STATUSES = ("failed", "unreadable", "violations", "intrusions", "incomplete", "pass")


@dataclass(frozen=True)
class Options:
    start: str | None = None  # --from
    stop: str | None = None  # --to
    timeout: float | None = None  # --timeout: seconds for one recording


class TimedOut(Exception):
    """A recording took longer than --timeout (checked as its messages are read)."""


_SPECS: dict[str, ir.Spec] = {}  # a worker's specs, by their JSON: parsed once


def spec_of(text: str) -> ir.Spec:
    spec = _SPECS.get(text)
    if spec is None:
        _SPECS.clear()
        spec = _SPECS[text] = ir.load(text)
    return spec


def replay_one(spec_json: str, job: Job | str, options: Options) -> dict[str, Any]:
    """The result of one recording (or of one section of it, `--chunk`): its path and
    status, what decided the status, the messages read and the time taken, and its
    records as JSON texts (those `rmv replay --format json` prints for it alone)."""
    job = job if isinstance(job, Job) else Job(job)
    path = job.path
    began = time.monotonic()
    deadline = None if options.timeout is None else began + options.timeout
    read = [0]

    def progress(done: int, total: int) -> None:
        read[0] = done
        if deadline is not None and time.monotonic() > deadline:
            raise TimedOut(f"took longer than --timeout {options.timeout:g} s")

    result: dict[str, Any] = {"path": path}
    texts: list[str] = []
    counts = {"violations": 0, "intrusions": 0, "warnings": 0}
    run_options = {"start": options.start, "stop": options.stop, "progress": progress}
    try:
        spec = spec_of(spec_json)
        with collection.for_streams():
            if job.section is not None:
                result["section"] = replay_section(spec, path, job.section, run_options, read)
                counts = result["section"]["counts"]
            else:
                for record in replay.replay(spec, [Path(path)], **run_options):  # type: ignore[arg-type]
                    tally(counts, texts, record)
    except TimedOut as why:
        result.update(status="failed", error=str(why), timed_out=True)
    except (ReplayError, ValueError, ZeroDivisionError) as why:
        result.update(status="unreadable", error=str(why))
    except Exception as why:  # rosbags' errors of a damaged file are of many kinds
        result.update(status="unreadable", error=f"{type(why).__name__}: {why}")
    else:
        result["status"] = status_of(counts)
    result.update(counts, messages=read[0], seconds=round(time.monotonic() - began, 3),
                  records=texts)  # fmt: skip
    return result


def failed(path: str, reason: str) -> dict[str, Any]:
    """The result of a recording no worker could finish."""
    return {"path": path, "status": "failed", "error": reason, "violations": 0,
            "intrusions": 0, "warnings": 0, "messages": 0, "seconds": 0.0,
            "records": []}  # fmt: skip
