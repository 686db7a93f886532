"""`--scheduler tcp://HOST:PORT`: the same work on an existing Dask distributed
cluster, through dask.distributed's own Client. The spec (its resolved IR's JSON)
is scattered to every worker once; each recording is one task; results come back
as they finish. A worker lost mid-task is the scheduler's to handle: it runs the
task again elsewhere, up to its `allowed-failures`, then the task fails with
KilledWorker and the recording is reported as failed with that reason. A recording
past --timeout gives up at its next batch of messages; one stuck where it cannot
look at the clock is cancelled and its worker restarted; either is submitted once
more, to another worker, then reported as failed. Every path must be readable by
the workers, as given (a shared file system)."""

from __future__ import annotations

import contextlib
import time
import uuid
from collections.abc import Callable
from typing import Any

from rmvdsl.lang.errors import UsageError
from rmvdsl.tools.fleet.sections import Job
from rmvdsl.tools.fleet.worker import Options, failed, replay_one

INSTALL = "pip install 'rmvdsl[fleet]'"
RESENDS = 3  # a task the cluster dropped (its input lost in a restart) is sent again
SHIP_TRIES = 5


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


class _Tasks:
    """The run's tasks: each job's attempts, where each ran, and how long each has
    been running (as the scheduler reports it)."""

    def __init__(self, client: Any, spec_json: str, options: Options, jobs: list[Job]) -> None:
        self.client, self.spec_json, self.options, self.jobs = client, spec_json, options, jobs
        self.spec = self.ship()
        self.run = uuid.uuid4().hex[:8]
        self.index_of: dict[str, int] = {}
        self.attempt: dict[int, int] = {}
        self.pending: dict[str, Any] = {}  # key -> future
        self.running_since: dict[str, float] = {}
        self.resent: dict[int, int] = {}

    def ship(self) -> Any:
        """The spec, on every worker (again after a restart took a worker's copy).
        A worker still restarting can refuse it: asked again, up to SHIP_TRIES
        times a second apart, before the run gives up."""
        for _ in range(SHIP_TRIES - 1):
            try:
                return self.client.scatter(self.spec_json, broadcast=True, hash=False)
            except Exception:  # Dask's comm and timeout errors, by their many names
                time.sleep(1.0)
        return self.client.scatter(self.spec_json, broadcast=True, hash=False)

    def submit(self, index: int, avoid: str | None = None, again: bool = False) -> None:
        """A job's next attempt (`again`: the same attempt, whose task the cluster
        dropped); a retry goes to another worker where there is one."""
        if not again:
            self.attempt[index] = self.attempt.get(index, 0) + 1
        attempt = self.attempt[index]
        self.resent[index] = self.resent.get(index, 0) + again
        key = f"rmv-replay-{self.run}-{index}-{attempt}-{self.resent[index]}"
        self.index_of[key] = index
        where: dict[str, Any] = {}
        others = [w for w in self.client.scheduler_info()["workers"] if w != avoid]
        if avoid is not None and others:
            where = {"workers": others, "allow_other_workers": True}
        self.pending[key] = self.client.submit(replay_one, self.spec, self.jobs[index],
                                               self.options, key=key, pure=False,
                                               **where)  # fmt: skip

    def stuck(self) -> list[tuple[str, str]]:
        """Tasks running past 1.5 x --timeout plus a second (stuck before their
        first message, where the replay cannot look at the clock), each with its
        worker: cancelled, and the worker restarted (its thread is not coming back)."""
        limit = self.options.timeout
        if limit is None:
            return []
        now = time.monotonic()
        found = []
        for worker, keys in self.client.processing().items():
            for key in keys:
                if key in self.pending:
                    since = self.running_since.setdefault(key, now)
                    if now - since > limit * 1.5 + 1:
                        found.append((key, worker))
        for key, worker in found:
            self.client.cancel(self.pending.pop(key))
            with contextlib.suppress(Exception):  # a worker without a nanny stays as it is
                self.client.restart_workers([worker], raise_for_error=False)
        if found:
            self.spec = self.ship()
        return found

    def finished(self) -> list[Any]:
        """The tasks done (or dropped by the cluster), waiting up to a second."""
        from distributed.client import FuturesCancelledError, wait

        try:
            return list(wait(list(self.pending.values()), timeout=1.0,
                             return_when="FIRST_COMPLETED").done)  # fmt: skip
        except TimeoutError:
            return []
        except FuturesCancelledError:  # a task whose input a restarted worker held
            return [f for f in self.pending.values() if f.cancelled()]


def run_on_cluster(client: Any, spec_json: str, options: Options, jobs: list[Job],
                   done: Callable[[int, dict[str, Any]], list[Job]]) -> None:  # fmt: skip
    """Run every job as a task; `done(index, result)` as each finishes, which may
    give more jobs (appended to `jobs`)."""
    tasks = _Tasks(client, spec_json, options, jobs)
    for index in range(len(jobs)):
        tasks.submit(index)
    limit = f"{options.timeout:g}" if options.timeout is not None else ""

    def settle(index: int, result: dict[str, Any], worker: str | None) -> None:
        """A result: a try past --timeout goes once more, elsewhere."""
        if result.get("timed_out") and tasks.attempt[index] < 2:
            tasks.submit(index, avoid=worker)
            return
        if result.get("timed_out"):
            result = {**result, "error": f"{result['error']}, twice"}
        for more in done(index, result):
            jobs.append(more)
            tasks.submit(len(jobs) - 1)

    try:
        while tasks.pending:
            for future in tasks.finished():
                if tasks.pending.pop(future.key, None) is None:
                    continue  # cancelled as stuck
                index = tasks.index_of[future.key]
                if future.cancelled() and tasks.resent.get(index, 0) < RESENDS:
                    tasks.submit(index, again=True)
                    continue
                worker = next(iter(client.who_has(future).get(future.key, ())), None)
                try:
                    result = future.result()
                except Exception as error:  # KilledWorker, or a worker without rmvdsl
                    result = failed(jobs[index].path, f"{type(error).__name__}: {error}")
                settle(index, result, worker)
            for key, worker in tasks.stuck():
                index = tasks.index_of[key]
                reason = f"took longer than --timeout {limit} s"
                settle(index, {**failed(jobs[index].path, reason), "timed_out": True}, worker)
    finally:  # Ctrl-C: what has not run does not
        client.cancel(list(tasks.pending.values()))
