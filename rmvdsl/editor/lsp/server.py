"""`rmv lsp`: a language server over stdio (pygls 2), thin over rmvdsl.editor.workspace.

Every feature is registered in `build()` (features.py; the server and its checks
in session.py, its state in state.py, what features look up in lookups.py, its
JSON-RPC protocol in protocol.py). Diagnostics are exactly `rmv
check`'s: the fast stages (loading, names, types) are published as soon as a change
is read, the solver stages after the text has rested for `DEBOUNCE` seconds; a
result that a newer change has overtaken is never published. Requests wait for the
fast stages of the text they were sent against.
"""

from __future__ import annotations

import asyncio
import gc
import sys

from lsprotocol import types

from rmvdsl.editor.lsp import features
from rmvdsl.editor.lsp.session import RmvServer
from rmvdsl.editor.workspace import warm_up

SWITCH_INTERVAL = 0.0005  # seconds
IDLE_SWEEP = 1.0  # seconds after the last change: a full collection, unnoticed
SWEEP_VALVE = 1000  # middle-generation collections between two full ones, at most


def build(own_process: bool = False) -> RmvServer:
    """The server with every feature registered. `own_process`: the process is the
    server's alone (`rmv lsp`), so the server may tune the whole interpreter's
    garbage collector; not when it runs beside other code (the LSP fuzz target)."""
    server = RmvServer()

    @server.feature(types.INITIALIZED)
    def initialized(ls: RmvServer, params: types.InitializedParams) -> None:
        # On the solver lane, idle until a document's text has rested: the first
        # completion would otherwise build the grammar's tables itself. Built while
        # the editor opens its first document, not beside its first keystrokes
        # (44 ms of CPU, which the first key after open waited for).
        ls.state.solver_lane.submit(warm_up)

    @server.feature(types.TEXT_DOCUMENT_DID_OPEN)
    async def did_open(ls: RmvServer, params: types.DidOpenTextDocumentParams) -> None:
        await ls.refresh(params.text_document.uri)
        if own_process:
            # What a first check built (parsed declarations, message definitions)
            # lives as long as the document: kept out of the collector's full
            # sweeps, which otherwise stall one keystroke in twenty by 50 ms on a
            # 2,000-line spec. Frozen at once, without a sweep (a sweep then
            # stalled a key typed meanwhile), and again at the first pause, after
            # the sweep the freeze put off (the idle sweep; a key typed meanwhile
            # arms it again): a typist who never paused met the valve's sweeps of
            # everything unfrozen, 495 ms on a 20,805-line spec, where one after
            # the freeze took 41 ms.
            gc.freeze()
            _sweep_when_idle(ls)

    @server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
    async def did_change(ls: RmvServer, params: types.DidChangeTextDocumentParams) -> None:
        if own_process:
            _sweep_when_idle(ls)
        await ls.refresh(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_SAVE)
    async def did_save(ls: RmvServer, params: types.DidSaveTextDocumentParams) -> None:
        await ls.refresh(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: RmvServer, params: types.DidCloseTextDocumentParams) -> None:
        path = ls.document(params.text_document.uri).path
        ls.state.workspace.close(path)
        ls.state.generation[path] = ls.state.generation.get(path, 0) + 1
        ls.state.solver.cancel(path)
        # Nothing of a closed document stays: its checks go, and a request still
        # waiting for one is answered now.
        ls.state.results.pop(path, None)
        ls.state.fast.pop(path, None)
        ls.state.mentions.pop(path, None)
        waiter = ls.state.analysed.pop(path, None)
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    features.register(server)
    return server


def _refreeze() -> None:
    gc.unfreeze()
    gc.collect()
    gc.freeze()


def _sweep_when_idle(ls: RmvServer) -> None:
    """A full collection once the typist has paused for IDLE_SWEEP seconds (the
    last one armed wins), on the fast lane, between two checks."""
    loop = asyncio.get_running_loop()
    if ls.state.idle_sweep is not None:
        ls.state.idle_sweep.cancel()
    ls.state.idle_sweep = loop.call_later(
        IDLE_SWEEP, lambda: loop.run_in_executor(ls.state.fast_lane, _refreeze)
    )


def main() -> None:
    # The event loop (reading requests, answering completion) and the lanes'
    # threads (a keystroke's check) share one interpreter: a thread that wants it
    # waits until the holder's switch interval ends, at every read and write of a
    # request. 5 ms by default; at 0.5 ms a request typed beside a check waits less.
    sys.setswitchinterval(SWITCH_INTERVAL)
    # The collector's full sweeps walk everything a keystroke's check left alive
    # since the last freeze: 100-150 ms on a 2,000-line spec, 4 of them in 400
    # keystrokes, each stalling the key it fell on (the p99). They run when the
    # typist pauses instead; while typing goes on, one at most every
    # SWEEP_VALVE collections of the middle generation (about 800 keys there), so
    # memory stays bounded for a typist who never pauses.
    first, second, _ = gc.get_threshold()
    gc.set_threshold(first, second, SWEEP_VALVE)
    build(own_process=True).start_io()
