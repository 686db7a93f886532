"""`--jobs N`: recordings replayed by N worker processes on this machine (serve.py,
each its own program). The spec goes to each worker once; a worker that dies
(kill -9, out of memory) or runs one recording past --timeout is replaced, its
recording retried once on another worker, then reported as failed with the reason.
Ctrl-C stops every worker."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from typing import Any

from rmvdsl.tools.fleet.sections import Job
from rmvdsl.tools.fleet.worker import Options, failed
from rmvdsl.util.processes import module_command

ATTEMPTS = 2  # a recording's first try and one retry


@dataclass
class _Worker:
    process: subprocess.Popen[bytes]
    jobs: Connection  # to the worker
    connection: Connection  # from the worker: its results
    job: tuple[int, Job] | None = None
    started: float = 0.0

    def alive(self) -> bool:
        return self.process.poll() is None

    def close(self) -> None:
        self.jobs.close()
        self.connection.close()


@dataclass
class LocalPool:
    spec_json: str
    jobs: int
    options: Options
    workers: list[_Worker] = field(default_factory=list)

    def _start(self) -> _Worker:
        """A worker: this interpreter running rmvdsl.tools.fleet.serve from the very
        rmvdsl this command runs, its pipes on two file descriptors."""
        jobs_read, jobs_write = os.pipe()
        results_read, results_write = os.pipe()
        command, env = module_command("rmvdsl.tools.fleet.serve")
        process = subprocess.Popen(
            [*command, str(jobs_read), str(results_write)],
            pass_fds=(jobs_read, results_write), cwd="/", env=env,
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
        )  # fmt: skip
        os.close(jobs_read)
        os.close(results_write)
        worker = _Worker(process, Connection(jobs_write), Connection(results_read))
        worker.jobs.send((self.spec_json, self.options))
        return worker

    def run(self, jobs: list[Job], done: Callable[[int, dict[str, Any]], list[Job]]) -> None:
        """Run every job; `done(index, result)` as each finishes, which may give more
        jobs (they are appended to `jobs`)."""
        pending = deque(enumerate(jobs))
        tries = [0] * len(jobs)
        tried_on: dict[int, int] = {}  # the process of a job's last try
        reasons: dict[int, str] = {}
        finished = [0]

        def settle(index: int, result: dict[str, Any] | None, reason: str = "") -> None:
            """A result, or a try that gave none: retried once, then final."""
            reason = result["error"] if result is not None and result.get("timed_out") else reason
            if reason and tries[index] < ATTEMPTS:
                reasons[index] = reason
                pending.appendleft((index, jobs[index]))
                return
            if reason:
                result = result or failed(jobs[index].path, reason)
                result["error"] = _twice(reasons.get(index, reason), reason)
            assert result is not None
            for more in done(index, result):
                pending.append((len(jobs), more))
                jobs.append(more)
                tries.append(0)
            finished[0] += 1

        self.workers = [self._start() for _ in range(min(self.jobs, len(jobs)))]
        try:
            while finished[0] < len(jobs):
                for worker in self.workers:
                    if worker.job is None and pending:
                        taken = _take(pending, worker.process.pid, tried_on, len(self.workers))
                        if taken is None:
                            continue
                        worker.job = taken
                        worker.started = time.monotonic()
                        tries[taken[0]] += 1
                        tried_on[taken[0]] = worker.process.pid
                        # A worker that died idle: _lost() sees it, and the job goes again.
                        with contextlib.suppress(OSError):
                            worker.jobs.send(worker.job)
                self._collect(settle)
                for index, reason in self._lost():
                    settle(index, None, reason)
        finally:
            self.stop()

    def _collect(self, settle: Callable[..., None]) -> None:
        busy = [w for w in self.workers if w.job is not None]
        ready = wait([w.connection for w in busy], 0.2)
        for worker in busy:
            if worker.connection in ready:
                try:
                    index, result = worker.connection.recv()
                except (EOFError, OSError):
                    continue  # it died: _lost() sees it
                worker.job = None
                settle(index, result)

    def _lost(self) -> list[tuple[int, str]]:
        """Recordings whose worker died or ran past --timeout; each such worker is
        replaced by a new one."""
        lost = []
        limit = self.options.timeout
        for position, worker in enumerate(self.workers):
            if worker.job is None:
                continue
            reason = None
            if not worker.alive():
                reason = _death(worker.process.returncode)
            elif limit is not None and time.monotonic() - worker.started > limit * 1.5 + 1:
                # A worker checks --timeout as it reads messages; one stuck before its
                # first message (a hung file system) is stopped from here.
                worker.process.kill()
                worker.process.wait()
                reason = f"took longer than --timeout {limit:g} s"
            if reason is not None:
                lost.append((worker.job[0], reason))
                worker.close()
                self.workers[position] = self._start()
        return lost

    def stop(self) -> None:
        for worker in self.workers:
            if worker.alive():
                worker.process.kill()
            worker.process.wait()
            worker.close()
        self.workers = []


def _take(pending: deque[tuple[int, Job]], pid: int, tried_on: dict[int, int],
          workers: int) -> tuple[int, Job] | None:  # fmt: skip
    """The next job for the worker `pid`: a retry goes to another worker (one that
    timed out stays alive, and may be what is wrong), unless there is no other."""
    for position, (index, job) in enumerate(pending):
        if workers == 1 or tried_on.get(index) != pid:
            del pending[position]
            return index, job
    return None


def _death(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"its worker died ({signal.Signals(-code).name})"
        except ValueError:
            pass
    return f"its worker exited with code {code}"


def _twice(first: str, second: str) -> str:
    return f"{first}; retried: {second}" if first != second else f"{first}, twice"
