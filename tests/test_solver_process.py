"""The editor's solver stages run in a process of their own, below the server's
priority (rmvdsl.editor.solver_process): its answers are a whole check's, a cancel
stops it, and it ends with the server or is started again when it dies."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from conftest import EXAMPLES
from lsp_wire import Wire

from rmvdsl.editor.solver_process import NICENESS, Solved, SolverEnded, SolverProcess
from rmvdsl.editor.workspace import Workspace

SPEC = EXAMPLES / "errors" / "properties.rmv"


def _documents(path: Path) -> dict[str, str]:
    return {str(path.resolve()): path.read_text(encoding="utf-8")}


def _whole_check(path: Path) -> list[tuple[str, int]]:
    result = Workspace().check(str(path.resolve()))
    return sorted((d.code, d.span.start) for d in result.diagnostics)


@pytest.fixture
def solver():
    process = SolverProcess()
    yield process
    process.close()


def test_its_answer_is_the_whole_check(solver: SolverProcess):
    answer = solver.solve(str(SPEC.resolve()), _documents(SPEC), lambda: False)
    assert isinstance(answer, Solved)
    assert sorted((d.code, d.span.start) for d in answer.diagnostics) == _whole_check(SPEC)
    assert any(d.code.startswith("RMV5") for d in answer.diagnostics)  # the solver's own
    assert answer.facts and all(len(found) == 2 for found in answer.facts.values())


def test_the_open_documents_are_what_it_checks(solver: SolverProcess, tmp_path: Path):
    """The text sent, not the file on disk (an editor's unsaved buffer)."""
    path = tmp_path / "unsaved.rmv"
    path.write_text("system unsaved\n", encoding="utf-8")
    typed = "system unsaved\nproperty P: Missing\n"
    answer = solver.solve(str(path), {str(path): typed}, lambda: False)
    assert isinstance(answer, Solved)
    assert [d.code for d in answer.diagnostics] == ["RMV200"]


def test_a_check_overtaken_meanwhile_is_stopped(solver: SolverProcess):
    assert solver.solve(str(SPEC.resolve()), _documents(SPEC), lambda: True) is None
    # and the next one is whole
    answer = solver.solve(str(SPEC.resolve()), _documents(SPEC), lambda: False)
    assert isinstance(answer, Solved)
    assert sorted((d.code, d.span.start) for d in answer.diagnostics) == _whole_check(SPEC)


def test_a_process_dying_in_a_check_is_reported_then_started_again(solver: SolverProcess):
    solver.solve(str(SPEC.resolve()), _documents(SPEC), lambda: False)
    first = solver._process
    assert first is not None

    def killed() -> bool:  # asked once the check is sent: the process dies in it
        first.kill()
        first.wait()
        return False

    with pytest.raises(SolverEnded, match="ended"):
        solver.solve(str(SPEC.resolve()), _documents(SPEC), killed)
    answer = solver.solve(str(SPEC.resolve()), _documents(SPEC), lambda: False)
    assert isinstance(answer, Solved) and solver._process is not first


def test_a_cancel_never_waits_for_the_process(solver: SolverProcess):
    """The event loop sends cancels: a process too busy to read its input (here
    stopped outright, a document's frame larger than the pipe's buffer waiting)
    must not hold it."""
    process = solver._started()
    os.kill(process.pid, signal.SIGSTOP)
    try:
        path = str(SPEC.resolve())

        def send() -> None:  # what `solve` sends, then what the event loop does
            solver._send(("check", 1, path, {path: "x" * 1_000_000}))
            solver._running = (1, path)
            solver.cancel(path)

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        sender.join(timeout=30)
        assert not sender.is_alive()
    finally:
        os.kill(process.pid, signal.SIGCONT)
        solver._running = None


def test_it_ends_when_the_server_does(solver: SolverProcess):
    solver.solve(str(SPEC.resolve()), _documents(SPEC), lambda: False)
    process = solver._process
    assert process is not None and process.stdin is not None
    process.stdin.close()  # what the server's end leaves
    assert process.wait(timeout=60) == 0


def _children(pid: int) -> list[int]:
    found = []
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/children", encoding="ascii") as listed:
            found += [int(child) for child in listed.read().split()]
    return found


def _niceness(pid: int) -> int:
    with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
        return int(stat.read().rsplit(")", 1)[1].split()[16])


def _running(pid: int) -> bool:
    """Alive, not a zombie waiting to be reaped."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_the_server_solves_in_a_lower_priority_process(tmp_path: Path):
    """The server's interpreter is the fast stages' alone: the solver stage's
    diagnostics come from a child process running below the server's priority."""
    wire = Wire(cwd=tmp_path)
    try:
        wire.initialize(SPEC.parent)
        uri = wire.open(SPEC, SPEC.read_text(encoding="utf-8"))
        wire.diagnostics_until(
            uri, lambda p: any(d["code"].startswith("RMV5") for d in p["diagnostics"])
        )
        server = wire.process.pid
        solvers = []
        deadline = time.monotonic() + 30
        while not solvers and time.monotonic() < deadline:
            for child in _children(server):
                with open(f"/proc/{child}/cmdline", "rb") as line:
                    if b"rmvdsl.editor.solver_process" in line.read():
                        solvers.append(child)
        assert len(solvers) == 1
        assert _niceness(server) == 0 and _niceness(solvers[0]) == NICENESS
        assert wire.close() == 0
        deadline = time.monotonic() + 30
        while _running(solvers[0]) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _running(solvers[0])  # it ended with the server
    finally:
        if wire.process.poll() is None:
            wire.process.kill()


def test_the_server_loads_no_solver():
    """z3 and the solver's modules load in the solver process only: the server's
    start and memory stay without them (69 MB at the first diagnostics of the
    benchmark's spec, 102 MB with them)."""
    code = (
        "import sys, rmvdsl.editor.lsp.server\n"
        "solver = ('z3', 'rmvdsl.logic.sat', 'rmvdsl.check.properties')\n"
        "print(sorted(m for m in sys.modules if m in solver))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
