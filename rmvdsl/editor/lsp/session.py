"""The language server (pygls 2) over its state (rmvdsl.editor.lsp.state): each
change checked, the fast stages' diagnostics published at once (by the edit path
where it answers, rmvdsl.check.edit), the solver stages' after a pause, and none
that a newer change overtook; diagnostics as `rmv check` gives them. What the
features look up in the checks is in rmvdsl.editor.lsp.lookups."""

from __future__ import annotations

import asyncio
import functools
import json
import sys
from collections import Counter
from typing import Any, BinaryIO, NamedTuple

from lsprotocol import types
from pygls.exceptions import JsonRpcInvalidParams, JsonRpcParseError

from rmvdsl import __version__
from rmvdsl.editor.lsp import convert
from rmvdsl.editor.lsp.lookups import Lookups
from rmvdsl.editor.lsp.protocol import Protocol, quiet_answered_failures
from rmvdsl.editor.lsp.state import State
from rmvdsl.editor.lsp.stdio import serve
from rmvdsl.editor.solver_process import Solved, SolverEnded
from rmvdsl.editor.workspace import CheckResult, EditCheck
from rmvdsl.lang.diagnostics import Diagnostic
from rmvdsl.lang.source import SourceMap

DEBOUNCE = 0.3  # seconds of quiet before the solver stages run
# Seconds of quiet before the fast stages of a key the edit path answered run:
# they only bring the model up to date (hover, definition, the solver stages).
SETTLE = 0.1


class _Answer(NamedTuple):
    """The edit path's answer to a key, and whether the fast stages must run at
    once to bring the check it was worked out from up to date (not the check
    itself: a change waiting for the solver lane holds no model)."""

    edit: EditCheck
    renew: bool


class RmvServer(Lookups):
    def __init__(self) -> None:
        super().__init__(
            "rmv-lsp",
            __version__,
            protocol_cls=Protocol,
            text_document_sync_kind=types.TextDocumentSyncKind.Incremental,
        )
        self.state = State()

    def start_io(self, stdin: BinaryIO | None = None, stdout: BinaryIO | None = None) -> None:
        """Serve over stdio (or the streams given) until the client ends it."""
        quiet_answered_failures()
        serve(self, stdin or sys.stdin.buffer, stdout or sys.stdout.buffer)

    def report_server_error(self, error: Exception, source: Any) -> None:
        """A frame that is not JSON (or not UTF-8) gets JSON-RPC's parse error (id
        null), and the user a warning; so does a notification with bad params (it
        has no answer to give). Any other error is pygls's message to the user."""
        if isinstance(error, (json.JSONDecodeError, UnicodeDecodeError)):
            why = "not JSON" if isinstance(error, json.JSONDecodeError) else "not UTF-8"
            assert isinstance(self.protocol, Protocol)
            self.protocol.answer_unknown(JsonRpcParseError(f"the message is {why}: {error}"))
            self.ignored(f"a message that is {why} ({error})")
        elif isinstance(error, JsonRpcInvalidParams):  # a notification's: no answer to give
            self.ignored(f"a notification: {error.message}")
        else:
            super().report_server_error(error, source)

    def ignored(self, what: str) -> None:
        """Tell the user what the server could not read (it goes on serving)."""
        self.window_show_message(
            types.ShowMessageParams(
                type=types.MessageType.Warning, message=f"rmv lsp ignored {what}"
            )
        )

    async def refresh(self, uri: str) -> None:
        """Check a document: the fast stages, then (if nothing changed meanwhile)
        the solver stages; publish each unless a newer change overtook it."""
        document = self.document(uri)
        path, state = document.path, self.state
        state.workspace.open(path, document.source)
        generation = state.generation[path] = state.generation.get(path, 0) + 1
        state.solver.cancel(path)  # a solver stage of the text before is wasted work
        self._waiter(path)  # what requests for this text wait for, from now
        answer = await self._publish_edit(path, generation, document.source)
        first = answer.edit if answer is not None else None
        newest = state.generation.get(path) == generation
        sent = first.diagnostics if first is not None and newest else None
        if answer is not None and answer.renew:
            # Answered from a check the text has since been edited far from: until
            # that check is brought up to date, each key rescans both places and
            # matches the chunks between (at 20,805 lines, 12 to 25 ms a key), and a
            # typist who never pauses overtakes each key before its fast stages
            # begin. They run now, on the newest text, overtaken or not (one at a
            # time).
            state.renewing.add(path)
            try:
                if not await self._publish_fast(path, generation, sent, overtaken_too=True):
                    return
            finally:
                state.renewing.discard(path)
        else:
            if first is not None:
                # A key answered already: its fast stages wait for a pause in the
                # typing, not run at each key, where they held the interpreter from
                # completions sent meanwhile (at 20,805 lines, 300 ms of CPU a key).
                await asyncio.sleep(SETTLE)
            if state.generation.get(path) != generation:
                return  # a newer key came meanwhile: its check answers
            if not await self._publish_fast(path, generation, sent):
                return
        # Waiting from here on holds no model: a wait for the solver lane can be
        # long (another document's solver stage), and a model held meanwhile, one
        # per waiting change, outlived its document (20,000-line files opened and
        # closed in turn grew the server by 25 MB a cycle).
        await asyncio.sleep(DEBOUNCE)
        if state.generation.get(path) != generation:
            return
        loop = asyncio.get_running_loop()
        full = functools.partial(self._solve_if_newest, path, generation)
        try:
            result = await loop.run_in_executor(state.solver_lane, full)
        except SolverEnded as ended:  # started again at the next change
            self.ignored(f"the solver stage of {path}: {ended}")
            return
        if result is not None and state.generation.get(path) == generation:
            self.publish(path, result)

    def _renews(self, path: str, found: EditCheck, base: CheckResult) -> bool:
        """Whether the edit path's answer, worked out from `base`, was far, and
        `base` is still what the edit path works from, with no fast stages running
        to replace it: a far key worked out while they ended (its answer came just
        after) would run them again on a text the next key is near (at 20,805
        lines, 500 ms of them beside the completions)."""
        state = self.state
        return found.far and path not in state.renewing and state.fast.get(path) is base

    async def _publish_edit(self, path: str, generation: int, text: str) -> _Answer | None:
        """The diagnostics of an edit inside a few declarations, worked out from the
        newest check when the lane is free (rmvdsl.check.edit) and published at
        once, unless a newer change overtook them (returned either way, with
        whether the fast stages must run now); None when the edit is not one of
        those (the fast stages answer first)."""
        state = self.state
        if path not in state.fast:
            return None
        edited = functools.partial(self._edit_if_newest, path, generation, text)
        try:
            found = await asyncio.get_running_loop().run_in_executor(state.edit_lane, edited)
        except Exception as error:  # a fault of the shortcut must not cost the key its check
            self.window_log_message(
                types.LogMessageParams(
                    types.MessageType.Error,
                    f"rmv lsp: the edit path failed ({error!r}); the fast stages answer",
                )
            )
            return None
        if found is None:
            return None
        edit, base = found
        if state.generation.get(path) == generation:
            self.send(path, edit.diagnostics, edit.sources)
        return _Answer(edit, self._renews(path, edit, base))

    async def _publish_fast(
        self,
        path: str,
        generation: int,
        sent: list[Diagnostic] | None = None,
        overtaken_too: bool = False,
    ) -> bool:
        """The fast stages of `generation`, published unless a newer change overtook
        them, or unless they found what was `sent` already for it; whether they were
        (requests waiting for the document are let go either way). Overtaken before
        they begin, they are skipped, unless `overtaken_too` (then they check the
        newest text, kept for the edit path, published by its own key)."""
        state = self.state
        loop = asyncio.get_running_loop()
        waiter = self._waiter(path)
        try:
            newest = None if overtaken_too else generation
            fast = functools.partial(self._check_if_newest, path, newest)
            result = await loop.run_in_executor(state.fast_lane, fast)
            if result is not None and state.workspace.text(path) is not None:
                # Kept even when a newer key overtook it: the edit path works out
                # the next keys from it. Dropped, a typist faster than the fast
                # stages left the edit path an ever older text, whose distance
                # from the new one it could not bridge, so every key ran the fast
                # stages (at 20,805 lines, 250 ms each) and fell further behind.
                state.fast[path] = result
            if result is None or state.generation.get(path) != generation:
                return False
            if sent is not None and Counter(sent) == Counter(result.diagnostics):
                state.results[path] = result  # the same diagnostics, sent already
            else:
                self.publish(path, result)
            return True
        finally:
            if state.generation.get(path) == generation and not waiter.done():
                waiter.set_result(None)  # published, or the check failed: stop waiting

    def _waiter(self, path: str) -> asyncio.Future[None]:
        """What requests for the document's newest text wait for (done once its fast
        stages are published)."""
        waiter = self.state.analysed.get(path)
        if waiter is None or waiter.done():
            waiter = self.state.analysed[path] = asyncio.get_running_loop().create_future()
        return waiter

    def _edit_if_newest(
        self, path: str, generation: int, text: str
    ) -> tuple[EditCheck, CheckResult] | None:
        """The edit path's answer to a key, unless a newer key overtook it while it
        waited for the lane: a typist asking for completion at each key does not
        wait for diagnostics, and each key's stale answer queued behind the others
        (at 20,805 lines, 1.8 s of them ahead of the next key's). Worked out from
        the newest check when its turn comes, not when the key came: a check
        finished meanwhile is nearer (a key queued while a far key's fast stages
        ran was answered from the check they replaced, far again, and ran them a
        second time, 500 ms beside the completions at 20,805 lines)."""
        before = self.state.fast.get(path)
        if before is None or self.state.generation.get(path) != generation:
            return None
        found = self.state.workspace.check_edit(path, text, before)
        return None if found is None else (found, before)

    def _check_if_newest(self, path: str, generation: int | None) -> CheckResult | None:
        """The fast stages of the document, unless a newer change overtook
        `generation` while it waited for the lane (a storm of edits queues one check
        each); whatever its text is now when `generation` is None."""
        if generation is not None and self.state.generation.get(path) != generation:
            return None
        return self.state.workspace.check(path, solver=False)

    def _solve_if_newest(self, path: str, generation: int) -> CheckResult | None:
        """The whole check of the document's text, in the solver process, stopped
        at its next checkpoint once a newer change arrives (its answer would be
        thrown away); with the fast stages' model of the same text, as published.
        SolverEnded if the process ended."""

        def overtaken() -> bool:
            return self.state.generation.get(path) != generation

        if overtaken():
            return None
        answer = self.state.solver.solve(path, self.state.workspace.documents(), overtaken)
        fast = self.state.results.get(path)
        if not isinstance(answer, Solved) or fast is None or overtaken():
            return None
        return answer.with_model(fast)

    def publish(self, root: str, result: CheckResult) -> None:
        """The diagnostics of a check, sent; the check takes the place of the one
        before once they are (letting go of a model, a copy of every declaration
        and its symbols, took about 1.4 ms of each keystroke's publication)."""
        self.send(root, result.diagnostics, result.model.sources)
        self.state.results[root] = result

    def send(self, root: str, diagnostics: list[Diagnostic], sources: SourceMap) -> None:
        """Diagnostics of the document `root` and what it imports, per file (an
        import's show in that file); a file shown before and clean now is cleared."""
        documents = self.open_documents()
        by_path: dict[str, list[types.Diagnostic]] = {root: []}
        for found in diagnostics:
            converted = convert.diagnostic(found, sources, self.encoding)
            if converted is not None:
                by_path.setdefault(found.span.path, []).append(converted)
        for stale in self.state.published.get(root, set()) - set(by_path):
            by_path[stale] = []
        self.state.published[root] = {p for p, items in by_path.items() if items}
        for path, items in by_path.items():
            version = documents[path].version if path in documents else None
            self.text_document_publish_diagnostics(
                types.PublishDiagnosticsParams(
                    uri=convert.uri_of(path), diagnostics=items, version=version
                )
            )
