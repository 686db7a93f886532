"""The JSON-RPC protocol under the language server: pygls's, keeping no finished
handler and answering every request, malformed ones included."""

from __future__ import annotations

import asyncio
import json
import logging
import sys
from typing import Any

from cattrs.errors import ClassValidationError
from pygls.exceptions import JsonRpcException, JsonRpcInvalidParams, JsonRpcInvalidRequest
from pygls.protocol import LanguageServerProtocol
from pygls.workspace import Workspace

from rmvdsl.editor.lsp.document import SplicingWorkspace


class Protocol(LanguageServerProtocol):
    """pygls's protocol, keeping no finished handler.

    pygls 2.1 files the future of every handler it runs under its message id, and
    only a request's answer takes it out: each notification's (two per didChange)
    stayed for the life of the server, about 2 KB an edit (found with tracemalloc
    over 1,000 edits). Here a future leaves the table once it is done, in the next
    turn of the event loop: pygls's shutdown cancels futures while iterating the
    table, and a cancelled future runs its callbacks at once."""

    # pygls makes the workspace at `initialize`: made one whose documents splice
    # their edits (rmvdsl.editor.lsp.document).
    @property
    def _workspace(self) -> Workspace | None:
        return self._spliced

    @_workspace.setter
    def _workspace(self, workspace: Workspace | None) -> None:
        if type(workspace) is Workspace:
            workspace.__class__ = SplicingWorkspace
        self._spliced = workspace

    def _execute_handler(self, msg_id: Any, *args: Any, **kwargs: Any) -> None:
        super()._execute_handler(msg_id, *args, **kwargs)
        future = self._request_futures.get(msg_id)
        if future is not None:
            loop = asyncio.get_running_loop()  # messages are handled on the loop
            future.add_done_callback(
                lambda done: loop.call_soon_threadsafe(self._forget, msg_id, done)
            )

    def _forget(self, msg_id: Any, future: Any) -> None:
        if self._request_futures.get(msg_id) is future:
            del self._request_futures[msg_id]

    # Every request gets an answer (JSON-RPC 2.0, section 5): pygls drops a request
    # whose params do not fit its type (a negative position) without one, and a
    # message that is no message at all with only a log line.

    def structure_message(self, data: dict[str, Any]) -> Any:
        try:
            return super().structure_message(data)
        except JsonRpcException as error:
            why = _validation_errors(error)
            if not {"jsonrpc", "id", "method"} <= set(data):
                raise JsonRpcInvalidParams(f"{data.get('method', 'a message')}: {why}") from None
            invalid = JsonRpcInvalidParams(f"{data['method']}: {why}")
            self._send_response(data["id"], None, invalid.to_response_error())
            return ANSWERED

    def handle_message(self, message: Any) -> None:
        if message is ANSWERED:
            return
        if not hasattr(message, "jsonrpc"):  # valid JSON, but not an object of JSON-RPC
            self.answer_unknown(JsonRpcInvalidRequest(
                "not a JSON-RPC message: expected an object with `jsonrpc`, `method` "
                "and `params`"))  # fmt: skip
            return
        super().handle_message(message)

    def answer_unknown(self, error: JsonRpcException) -> None:
        """An error answering a message whose id could not be read: `"id": null`,
        written out (pygls leaves a None id out of the message)."""
        answer = {"code": error.code, "message": error.message}
        self._send_data({"jsonrpc": "2.0", "id": None, "error": answer})


ANSWERED = object()  # a request structure_message has answered with an error

# Failures of a message that the server answers itself (Protocol.structure_message,
# rmvdsl.editor.lsp.session.RmvServer.report_server_error): a frame that is not
# JSON or not UTF-8, params of the wrong shape.
ANSWERED_FAILURES = (
    json.JSONDecodeError,
    UnicodeDecodeError,
    JsonRpcInvalidParams,
    ClassValidationError,
)


def quiet_answered_failures() -> None:
    """pygls's loggers, but for their records of the failures the server answers:
    pygls logs each with its traceback on stderr (an editor's log of the server),
    besides the answer the client gets."""
    for name in ("pygls.server", "pygls.protocol.json_rpc"):
        logger = logging.getLogger(name)
        if not any(isinstance(f, _Answered) for f in logger.filters):
            logger.addFilter(_Answered())


class _Answered(logging.Filter):
    """Drops a record logged while a failure the server answers is handled."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not isinstance(sys.exc_info()[1], ANSWERED_FAILURES)


def _validation_errors(error: BaseException) -> str:
    """What was wrong with a message's params, in lsprotocol's words (the leaves
    of cattrs's exception groups), at most three."""
    leaves: list[str] = []
    pending: list[BaseException] = [error.__cause__ or error]
    while pending and len(leaves) < 3:
        found = pending.pop(0)
        inner = getattr(found, "exceptions", None)  # an exception group
        if inner:
            pending[:0] = list(inner)
        elif isinstance(found, KeyError):
            leaves.append(f"`{found.args[0]}` is missing")
        elif isinstance(found, ValueError) and str(found):
            leaves.append(str(found))  # lsprotocol's validators say what was wanted
        else:  # a TypeError of Python's: name the attribute, as cattrs noted it
            notes = getattr(found, "__notes__", [])
            where = [n.rpartition("@ attribute ")[2] for n in notes if "@ attribute " in n]
            leaves.append(
                f"`{where[0]}` has the wrong type" if where else "a value of the wrong type"
            )
    return "; ".join(leaves) or "params of the wrong shape"
