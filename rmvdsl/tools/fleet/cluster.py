"""`--scheduler tcp://HOST:PORT`: the same work on an existing Dask distributed
cluster, through dask.distributed's own Client. The spec (its resolved IR's JSON)
is scattered to every worker once; each recording is one task; results come back
as they finish. A worker lost mid-task is the scheduler's to handle: it runs the
task again elsewhere, up to its `allowed-failures`, then the task fails with
KilledWorker and the recording is reported as failed with that reason. A recording
past --timeout gives up at its next batch of messages and is submitted once more.
Every path must be readable by the workers, as given (a shared file system)."""

from __future__ import annotations

import uuid
from collections.abc import Callable
from typing import Any

from rmvdsl.lang.errors import UsageError
from rmvdsl.tools.fleet.sections import Job
from rmvdsl.tools.fleet.worker import Options, failed, replay_one

INSTALL = "pip install 'rmvdsl[fleet]'"


def client_for(address: str) -> Any:
    """A Client connected to the scheduler at `address` (exit 2 without Dask, or
    when no scheduler answers there)."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise UsageError(f"--scheduler needs Dask: {INSTALL}") from None
    try:
        return Client(address, timeout="10s")
    except (OSError, TimeoutError) as error:
        raise UsageError(f"--scheduler {address}: no Dask scheduler answers: {error}") from None


def run_on_cluster(client: Any, spec_json: str, options: Options, jobs: list[Job],
                   done: Callable[[int, dict[str, Any]], list[Job]]) -> None:  # fmt: skip
    """Run every job as a task; `done(index, result)` as each finishes, which may
    give more jobs (appended to `jobs`)."""
    from dask.distributed import as_completed

    run = uuid.uuid4().hex[:8]
    shipped = client.scatter(spec_json, broadcast=True, hash=False)
    index_of: dict[str, int] = {}
    submitted: list[Any] = []

    def submit(index: int, attempt: int) -> Any:
        key = f"rmv-replay-{run}-{index}-{attempt}"
        index_of[key] = index
        future = client.submit(replay_one, shipped, jobs[index], options, key=key, pure=False)
        submitted.append(future)
        return future

    futures = as_completed([submit(i, 1) for i in range(len(jobs))])
    retried: set[int] = set()
    try:
        for future in futures:
            index = index_of[future.key]
            try:
                result = future.result()
            except Exception as error:  # KilledWorker, or a worker without rmvdsl
                result = failed(jobs[index].path, f"{type(error).__name__}: {error}")
            if result.get("timed_out") and index not in retried:
                retried.add(index)
                futures.add(submit(index, 2))
                continue
            if result.get("timed_out"):
                result = {**result, "error": f"{result['error']}, twice"}
            for more in done(index, result):
                jobs.append(more)
                futures.add(submit(len(jobs) - 1, 1))
    finally:  # Ctrl-C: what has not run does not
        client.cancel([f for f in submitted if not f.done()])
