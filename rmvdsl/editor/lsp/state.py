"""The language server's state: its workspace, each document's change count, its
newest checks, and the threads ("lanes") checks run in (rmvdsl.editor.lsp.session
schedules them)."""

from __future__ import annotations

import asyncio
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from rmvdsl.editor.mentions import Mention
from rmvdsl.editor.solver_process import SolverProcess
from rmvdsl.editor.workspace import CheckResult, Workspace


@dataclass
class State:
    """The server's view: the workspace, each document's change count, and the
    newest check of each document."""

    # Incremental: a keystroke re-checks only what it could change.
    workspace: Workspace = field(default_factory=lambda: Workspace(incremental=True))
    generation: dict[str, int] = field(default_factory=dict)
    results: dict[str, CheckResult] = field(default_factory=dict)
    # The newest finished check of each document's fast stages alone, of the text
    # it read (a newer key may have changed it since): what the diagnostics of an
    # edit inside a few declarations are worked out from (the results may hold the
    # solver stages' too, which an edit makes old).
    fast: dict[str, CheckResult] = field(default_factory=dict)
    # Two lanes: the fast stages (what a keystroke must show at once) never queue
    # behind a solver stage; solver stages run one at a time, and one queued for a
    # text that has changed since is skipped when its turn comes. The solver lane's
    # thread only waits: the stages run in the solver process.
    fast_lane: ThreadPoolExecutor = field(default_factory=lambda: _lane("rmv-fast"))
    # The diagnostics of an edit inside a few declarations (rmvdsl.check.edit) are
    # worked out off the event loop: a completion sent with the key is answered
    # meanwhile.
    edit_lane: ThreadPoolExecutor = field(default_factory=lambda: _lane("rmv-edit"))
    solver_lane: ThreadPoolExecutor = field(default_factory=lambda: _lane("rmv-solver"))
    solver: SolverProcess = field(default_factory=SolverProcess)
    published: dict[str, set[str]] = field(default_factory=dict)  # root -> paths shown
    mentions: dict[str, tuple[CheckResult, list[Mention]]] = field(default_factory=dict)
    # path -> done when the fast stages of its newest text have been published
    analysed: dict[str, asyncio.Future[None]] = field(default_factory=dict)
    idle_sweep: asyncio.TimerHandle | None = None  # the next full collection (server.py)
    # Paths whose fast stages run now for the edit path, overtaken or not (session.refresh)
    renewing: set[str] = field(default_factory=set)


def _lane(name: str) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(1, thread_name_prefix=name)
