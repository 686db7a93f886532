"""The editor's solver stages in a process of their own, at a lower priority
(`python -m rmvdsl.editor.solver_process`, started by the language server).

In the server's process a solver stage shared the interpreter with the fast
stages of the next keystroke until it reached a checkpoint: on a 20,000-line spec
a typist pausing past the debounce waited twice as long for a key's diagnostics
as one who did not pause. Here the server's interpreter only ever serves the
editor; the solver stage runs beside it, and its processes (and the workers they
start) yield the cores to it.

The server sends `("check", number, path, documents)` and `("cancel", number)`
frames (rmvdsl.util.processes); the process answers each check with `(number,
answer)`: Solved, None when it was cancelled, or the text of an error. It keeps an
incremental Workspace of its own, so a check re-does the fast stages of only what
changed, then the solver stages, which a cancel stops at their next checkpoint
(rmvdsl.util.cancel). It ends when the server's end of its input closes.
"""

from __future__ import annotations

import atexit
import contextlib
import dataclasses
import functools
import itertools
import os
import pickle
import queue
import subprocess
import sys
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import IO, TYPE_CHECKING, Any

from rmvdsl.check import CheckResult
from rmvdsl.check.property_findings import PropertyFacts, PropertyReport
from rmvdsl.editor.workspace import Workspace
from rmvdsl.lang.diagnostics import Diagnostic
from rmvdsl.util.cancel import Cancelled, stoppable
from rmvdsl.util.processes import module_command, read_frame, write_frame

if TYPE_CHECKING:  # the solver's modules load in the solver process only
    from rmvdsl.logic.answers import Answer

NICENESS = 10  # the solver process's (and its workers') priority below the server's


@dataclass(frozen=True)
class Solved:
    """What a whole check found: its diagnostics, and per property whether it can
    hold and whether it always holds (what hover shows; witnesses stay behind)."""

    diagnostics: list[Diagnostic]
    facts: dict[str, tuple[Answer | None, Answer | None]]

    def with_model(self, fast: CheckResult) -> CheckResult:
        """The whole check, with the model of the fast stages' check of the same
        text (the server's, which its features read)."""
        facts = {name: PropertyFacts(None, *found) for name, found in self.facts.items()}
        return CheckResult(fast.model, self.diagnostics, fast.types, None, PropertyReport(facts))


class SolverEnded(RuntimeError):
    """The solver process ended (or broke its pipe) before answering."""


class SolverProcess:
    """The server's side: one process, started at the first check and again after
    it ends. `solve` is called by one thread at a time (the server's solver lane);
    `cancel` by any, and never waits: what is sent is written by a thread of the
    process's own (a busy process drains a 2,000-line document's frame slowly, and
    the event loop sending a cancel waited for it, 136 ms once)."""

    def __init__(self) -> None:
        self._process: subprocess.Popen[bytes] | None = None
        self._outbox: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self._numbers = itertools.count(1)
        self._running: tuple[int, str] | None = None
        atexit.register(self.close)

    def solve(self, path: str, documents: dict[str, str], overtaken: Callable[[], bool]) -> Any:
        """The whole check of `path` with these open documents: Solved, or None
        once `overtaken()` (or a cancel for `path`) stopped it. SolverEnded if the
        process ended; RuntimeError with its traceback if the check raised."""
        process = self._started()
        number = next(self._numbers)
        self._running = (number, path)
        try:
            self._send(("check", number, path, documents))
            if overtaken():  # a change that came before `_running` said what runs
                self._send(("cancel", number))
            assert process.stdout is not None
            while (frame := read_frame(process.stdout)) is not None:
                answered, answer = pickle.loads(frame)
                if answered == number:
                    if isinstance(answer, str):
                        raise RuntimeError(f"the solver stage failed:\n{answer}")
                    return answer
        finally:
            self._running = None
        status = process.wait()
        self._process = None
        raise SolverEnded(f"the solver process ended (status {status})")

    def cancel(self, path: str) -> None:
        """Stop the check of `path` that runs now, if one does."""
        running = self._running
        if running is not None and running[1] == path:
            self._send(("cancel", running[0]))

    def close(self) -> None:
        if self._process is not None and self._process.poll() is None:
            self._process.kill()
            self._process.wait()

    def _started(self) -> subprocess.Popen[bytes]:
        if self._process is None or self._process.poll() is not None:
            command, env = module_command("rmvdsl.editor.solver_process")
            process = subprocess.Popen(
                command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env
            )
            self._outbox.put(None)  # the writer of the process before ends
            self._outbox = queue.SimpleQueue()
            writer = threading.Thread(
                target=_write_all, args=(self._outbox, process.stdin), daemon=True
            )
            writer.start()
            self._process = process
        return self._process

    def _send(self, message: tuple[Any, ...]) -> None:
        self._outbox.put(pickle.dumps(message, pickle.HIGHEST_PROTOCOL))


def _write_all(outbox: queue.SimpleQueue[bytes | None], stream: IO[bytes] | None) -> None:
    """A process's input, in the order sent, until it ends (then `solve` says so)
    or another process takes its place (None)."""
    assert stream is not None
    with contextlib.suppress(OSError):
        while (payload := outbox.get()) is not None:
            write_frame(stream, payload)


# ---- the process ----


def solved(result: CheckResult) -> Solved:
    facts = {}
    if result.properties is not None:
        for name, found in result.properties.facts.items():
            facts[name] = (_bare(found.satisfiable), _bare(found.valid))
    return Solved(result.diagnostics, facts)


def _bare(answer: Answer | None) -> Answer | None:
    return None if answer is None else dataclasses.replace(answer, witness=None)


def serve(source: IO[bytes], sink: IO[bytes]) -> None:
    """Checks in, answers out, in order; cancels are read meanwhile by a thread of
    their own. The process ends when `source` does."""
    checks: queue.SimpleQueue[tuple[Any, ...]] = queue.SimpleQueue()
    cancelled: set[int] = set()

    def read() -> None:
        while (frame := read_frame(source)) is not None:
            message = pickle.loads(frame)
            if message[0] == "cancel":
                cancelled.add(message[1])
            else:
                checks.put(message)
        os._exit(0)  # the server is gone: nothing to answer to

    threading.Thread(target=read, name="rmv-solver-input", daemon=True).start()
    workspace = Workspace(incremental=True)
    while True:
        _, number, path, documents = checks.get()
        answer: Any = None
        if number not in cancelled:
            workspace.show(documents)
            try:
                with stoppable(functools.partial(cancelled.__contains__, number)):
                    answer = solved(workspace.check(path, solver=True))
            except Cancelled:
                answer = None
            except Exception:  # the server shows it, as it showed an error in process
                answer = traceback.format_exc()
        cancelled.discard(number)
        try:
            frame = pickle.dumps((number, answer), pickle.HIGHEST_PROTOCOL)
        except Exception:  # (a diagnostic holding what cannot be pickled)
            frame = pickle.dumps((number, traceback.format_exc()), pickle.HIGHEST_PROTOCOL)
        write_frame(sink, frame)


def main() -> None:
    with contextlib.suppress(OSError):
        os.nice(NICENESS)
    # The frames go to the process's own output; anything printed goes to its errors.
    sink = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    serve(sys.stdin.buffer, sink)


if __name__ == "__main__":
    # Run as the module by its name, not as __main__: what it pickles (Solved) is
    # then found by that name in the server.
    from rmvdsl.editor import solver_process

    solver_process.main()
