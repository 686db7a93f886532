"""Solver questions answered in parallel, across processes (docs/verification.md).

z3 holds the GIL while it solves and its Python objects may not cross threads, so
independent questions go to worker processes: each worker answers a batch of
questions over the same propositions (one group of properties, whose encodings it
then shares), in order, on a deep stack like the checker's. The parent keeps the
answers in the same cache as answers found in process, so a parallel check and a
sequential one leave the same cache and read the same answers; answers cut short
by a time limit are returned too (not cached), so that they are not asked again in
the same check.

A worker is `python -m rmvdsl.logic.parallel`, reading batches from its standard
input and writing answers to its standard output (pickled, length first): unlike
multiprocessing's spawn, it never imports the caller's main module, and unlike
fork it is safe beside the editor's threads. Workers start once and serve later
checks. A batch that cannot be sent (a formula nested too deep to pickle) or a
worker that dies leaves its questions unanswered: the sequential pass asks them
in process.
"""

from __future__ import annotations

import atexit
import contextlib
import importlib
import os
import pickle
import queue
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import IO, Any

from rmvdsl.logic.answers import Answer, Witness
from rmvdsl.logic.canonical import canonical, cut_system
from rmvdsl.logic.redundancy import group_key, implied
from rmvdsl.logic.sat import Limits, cached_answer, keep, question_key, solve
from rmvdsl.logic.system import System
from rmvdsl.util.cache import Cache
from rmvdsl.util.processes import module_command, read_frame, write_frame

# Below this many unanswered questions, waking workers costs more than it saves.
LEAST_PARALLEL = 8

# A question: its formulas and system, and optionally whether a trace found by an
# earlier question of its batch may answer it (rmvdsl.logic.sat.by_trace).
Question = tuple[Sequence[Any], System | None] | tuple[Sequence[Any], System | None, bool]
Batch = list[tuple[Sequence[Any], System, bool]]

_WORKERS: list[_Worker] = []
_WORKERS_LOCK = threading.Lock()


def jobs_wanted(limits: Limits) -> int:
    """The processes a check uses: `limits.jobs`, else one per usable core."""
    if limits.jobs is not None:
        return max(1, limits.jobs)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def answer_all(
    batches: Sequence[Sequence[Question]], limits: Limits, cache: Cache
) -> dict[str, Answer]:
    """Answer the questions of `batches` that `cache` does not hold, in parallel;
    every answer found is returned by its key (and kept in `cache` unless a time
    limit cut it short). Each batch goes to one worker, in order."""
    jobs = jobs_wanted(limits)
    if jobs < 2:
        return {}  # the check asks them in process, in order
    pending: list[tuple[list[str], Batch]] = []
    asked: set[str] = set()  # each canonical question once (rmvdsl.logic.canonical)
    for batch in batches:
        keys, todo = [], []
        for formulas, system, *traced in batch:
            key, restricted = question_key(formulas, system, limits)
            if key not in asked and cached_answer(cache, key) is None:
                asked.add(key)
                keys.append(key)
                todo.append((formulas, restricted, bool(traced and traced[0])))
        if todo:
            pending.append((keys, todo))
    if sum(len(todo) for _, todo in pending) < LEAST_PARALLEL:
        return {}
    tasks = [(_answer_batch, (todo, limits)) for _, todo in pending]
    found: dict[str, Answer] = {}
    for (keys, _), answers in zip(pending, run_tasks(tasks, jobs), strict=True):
        for key, data in zip(keys, answers or (), strict=False):
            if data.get("key") != key:  # named otherwise than here: asked in process
                continue
            answer = Answer.from_json(data)  # canonical, as the cache keeps it
            keep(cache, key, answer)
            found[key] = answer
    return found


def implied_all(
    groups: Sequence[tuple[Sequence[str], Sequence[Any], Sequence[Witness]]],
    system: System,
    limits: Limits,
    cache: Cache,
) -> list[list[tuple[str, list[str]]]]:
    """`redundancy.implied` of each group (names, formulas, known traces); the
    groups whose answer the cache lacks are answered by the workers first (a
    group whose questions a time limit cut short is asked again in process)."""
    jobs = jobs_wanted(limits)
    missing: dict[str, int] = {}  # a group's key -> the first group asked with it
    for index, (_, formulas, _) in enumerate(groups if jobs > 1 else ()):
        key = group_key(formulas, system, limits)
        if key not in missing and cache.get(key) is None:
            missing[key] = index
    # A group's redundancy is mostly answered by the traces at hand: below
    # LEAST_PARALLEL groups, waking workers costs more than it saves (an editor's
    # two changed groups of five started two workers, 120 MB, for a few questions).
    if len(missing) >= LEAST_PARALLEL:
        # Each group's task carries only the part of the system its formulas touch:
        # the whole system in every task was quadratic (the 10x spec's 1,000 groups
        # each pickled 1,000 transducers). Every question cuts it the same way.
        tasks = [
            (_implied_here, (*groups[i], cut_system(groups[i][1], system), limits))
            for i in missing.values()
        ]
        for reply in run_tasks(tasks, jobs):
            for key, data in reply or ():
                cache.put(key, data)
    return [
        implied(names, formulas, system, limits, cache, known) for names, formulas, known in groups
    ]


# Told of each task done, with the count of tasks, where a terminal shows progress
# (`rmv check` sets it; rmvdsl.commands.check).
Progress = Callable[[int, int], None]
_progress: list[Progress] = []


@contextlib.contextmanager
def progress(report: Progress) -> Iterator[None]:
    """`report(done, total)` after each task the workers finish, while inside."""
    _progress.append(report)
    try:
        yield
    finally:
        _progress.remove(report)


def run_tasks(tasks: Sequence[tuple[Callable[..., Any], tuple[Any, ...]]], jobs: int) -> list[Any]:
    """Each task's result, in order, computed by `jobs` workers (each fed by a
    thread of its own, which waits on a pipe, not on the GIL); None where a task
    could not be sent or its worker died, and for every task when `jobs` < 2."""
    results: list[Any] = [None] * len(tasks)
    if jobs < 2 or not tasks:
        return results
    todo: queue.SimpleQueue[int] = queue.SimpleQueue()
    for index in range(len(tasks)):
        todo.put(index)
    lock, done = threading.Lock(), [0]

    def serve(worker: _Worker) -> None:
        while True:
            try:
                index = todo.get_nowait()
            except queue.Empty:
                return
            function, args = tasks[index]
            results[index] = worker.call(function, args)
            with lock:
                done[0] += 1
                for report in _progress:
                    report(done[0], len(tasks))

    threads = [
        threading.Thread(target=serve, args=(w,), daemon=True)
        for w in _workers(min(jobs, len(tasks)))
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return results


# ---- what workers run ----


def _answer_batch(batch: Batch, limits: Limits) -> list[dict[str, Any]]:
    """The batch's canonical answers in order, each with its key (the parent keeps
    an answer only under the same key); a question marked so is answered by a
    trace an earlier one found where one does (a property's antecedents, by the
    traces where it holds and where it fails), else by the solver."""
    known: list[Witness] = []  # in the batch's own names
    answers = []
    for formulas, system, traced in batch:
        question = canonical(formulas, system, limits)
        answer = solve(question, known if traced else (), limits)
        witness = question.real(answer).witness
        if witness is not None:
            known.append(witness)
        answers.append({**answer.as_json(), "key": question.key})
    return answers


def _implied_here(
    names: Sequence[str],
    formulas: Sequence[Any],
    known: Sequence[Witness],
    system: System,
    limits: Limits,
) -> list[tuple[str, dict[str, Any]]]:
    """`implied`, for the parent's cache: what it kept (the group's answer and
    those of its questions)."""
    cache = _Recording()
    implied(names, formulas, system, limits, cache, known)
    return cache.kept


@dataclass
class _Recording(Cache):
    """An in-memory cache that lists what was kept in it."""

    kept: list[tuple[str, dict[str, Any]]] = field(default_factory=list)

    def put(self, key: str, value: dict[str, Any]) -> None:
        super().put(key, value)
        self.kept.append((key, value))


class _Worker:
    def __init__(self) -> None:
        command, env = module_command("rmvdsl.logic.parallel")
        self.process = subprocess.Popen(
            command,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=env,
        )
        self.turn = threading.Lock()

    @property
    def alive(self) -> bool:
        return self.process.poll() is None

    def call(self, function: Callable[..., Any], args: tuple[Any, ...]) -> Any:
        """`function(*args)` in the worker; None if it could not be sent or the
        worker died."""
        try:
            request = (function.__module__, function.__qualname__, args)
            payload = pickle.dumps(request, protocol=pickle.HIGHEST_PROTOCOL)
        except (RecursionError, pickle.PicklingError):
            return None
        assert self.process.stdin is not None and self.process.stdout is not None
        with self.turn:  # one request at a time on the pipe, whoever asks
            try:
                write_frame(self.process.stdin, payload)
                reply = read_frame(self.process.stdout)
            except OSError:
                reply = None
        if reply is None:
            self.process.kill()
            return None
        return pickle.loads(reply)


def _workers(count: int) -> list[_Worker]:
    with _WORKERS_LOCK:
        _WORKERS[:] = [w for w in _WORKERS if w.alive]
        while len(_WORKERS) < count:
            _WORKERS.append(_Worker())
        return _WORKERS[:count]


@atexit.register
def _stop_workers() -> None:
    alive = [worker for worker in _WORKERS if worker.alive]
    for worker in alive:
        worker.process.kill()
    for worker in alive:  # reaped: their time is the command's (`time rmv check`)
        with contextlib.suppress(subprocess.TimeoutExpired):
            worker.process.wait(timeout=5)


def serve(source: IO[bytes], sink: IO[bytes]) -> None:
    """A worker's loop: a call in, its result out, until the input ends. Only the
    parent writes to this process's input (a pipe), naming its own functions."""
    while (request := read_frame(source)) is not None:
        module, name, args = pickle.loads(request)
        result = getattr(importlib.import_module(module), name)(*args)
        write_frame(sink, pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))


if __name__ == "__main__":
    from rmvdsl.util.deep import deep

    deep(serve, sys.stdin.buffer, sys.stdout.buffer)
