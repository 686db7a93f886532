"""The LSP target: one `rmv lsp` server for the whole run, each input a sequence
of what an editor (or a broken one) may send, read from the input's bytes: edits
at any range, whole texts, requests at any position, cancellations, closes and
opens, and raw frames. After each input every request must have its answer, and
no answer may be an internal error (-32603) nor any message a server error.

The server is `rmv lsp`'s (rmvdsl.editor.lsp.server.build), run in a thread of
the fuzzing process over two pipes: its code is instrumented as the harness's is,
so atheris's coverage of the server guides the inputs. Its stdio process is what
the edge tests and the editor clients' tests (tests/test_lsp*.py) talk to."""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

from fuzz.targets import EXAMPLES, Crash, OneInput

ANSWER_WAIT = 30.0  # seconds: a check of what an input typed, on a loaded machine
REQUESTS = ("textDocument/hover", "textDocument/definition", "textDocument/references",
            "textDocument/completion", "textDocument/semanticTokens/full",
            "textDocument/foldingRange", "textDocument/documentSymbol", "textDocument/rename",
            "textDocument/formatting", "textDocument/codeAction", "workspace/symbol")  # fmt: skip


class Bytes:
    """The input read as choices, a byte or a few at a time (zeros when it ends)."""

    def __init__(self, data: bytes) -> None:
        self.data, self.at = data, 0

    def left(self) -> bool:
        return self.at < len(self.data)

    def byte(self) -> int:
        value = self.data[self.at] if self.at < len(self.data) else 0
        self.at += 1
        return value

    def number(self) -> int:
        """Mostly small, sometimes negative or huge: positions a client may send."""
        kind, value = self.byte(), self.byte()
        if kind < 200:
            return value % 40
        return [-1, 2**31 - 1, 2**31, value * 1000][kind % 4]

    def text(self) -> str:
        size = self.byte() % 64
        chunk = self.data[self.at : self.at + size]
        self.at += size
        return chunk.decode("utf-8", errors="replace")


def prepare(folder: Path) -> OneInput:
    from lsp_wire import Wire

    # The server's log reports each request it refused (bad params): written by
    # the thousand, and judged here from the answers instead.
    logging.getLogger("pygls").setLevel(logging.CRITICAL)
    wire = Wire(cwd=folder, in_process=True)
    wire.initialize(folder)
    path = folder / "doc.rmv"
    seed = (EXAMPLES / "carla" / "abs.rmv").read_text(encoding="utf-8")
    path.write_text(seed, encoding="utf-8")
    state = {"version": 1, "uri": wire.open(path, seed)}

    def one(data: bytes) -> None:
        if wire.process.poll() is not None:
            said = wire.stderr[-2000:].decode(errors="replace")
            raise Crash(f"the server ended ({wire.process.returncode}): {said}")
        mark, asked = len(wire.seen), []
        ops = Bytes(data)
        while ops.left():
            sent = _send_one(wire, ops, state)
            if sent is not None:
                asked.append(sent)
        asked.append(
            wire.request("textDocument/documentSymbol", {"textDocument": {"uri": state["uri"]}})
        )
        for number in asked:
            try:
                wire.answer(number, ANSWER_WAIT)
            except TimeoutError:
                raise Crash(f"request {number} had no answer in {ANSWER_WAIT} s") from None
            except EOFError:
                wire.stderr_reader.join(5)
                raise Crash(
                    f"the server ended: {wire.stderr[-3000:].decode(errors='replace')}"
                ) from None
        _judge(wire.seen[mark:])
        del wire.seen[:]  # what was judged: memory stays flat over a long run

    return one


def _send_one(wire: Any, ops: Bytes, state: dict[str, Any]) -> int | None:
    """One message chosen by the input; a request's id."""
    choice, uri = ops.byte() % 8, state["uri"]
    if choice in (0, 1, 2):  # an edit: any range, sometimes past the end
        state["version"] += 1 if ops.byte() % 8 else -3  # now and then out of order
        start = {"line": ops.number(), "character": ops.number()}
        end = {"line": start["line"] + ops.byte() % 3, "character": ops.number()}
        change = {"range": {"start": start, "end": end}, "text": ops.text()}
        _change(wire, uri, state["version"], change)
        return None
    if choice == 3:
        method = REQUESTS[ops.byte() % len(REQUESTS)]
        position = {"line": ops.number(), "character": ops.number()}
        params: dict[str, Any] = {"textDocument": {"uri": uri}, "position": position,
                                  "newName": ops.text(), "query": ops.text(),
                                  "context": {"includeDeclaration": True, "diagnostics": []},
                                  "range": {"start": position, "end": position},
                                  "options": {"tabSize": 4, "insertSpaces": True}}  # fmt: skip
        return wire.request(method, params)
    if choice == 4 and wire.next_id:
        wire.notify("$/cancelRequest", {"id": wire.next_id})
        return None
    if choice == 5:  # the whole text replaced by what the input says
        state["version"] += 1
        _change(wire, uri, state["version"], {"text": ops.text()})
        return None
    if choice == 6:
        wire.notify("textDocument/didClose", {"textDocument": {"uri": uri}})
        state["version"] = 1
        wire.open(Path(uri[len("file://") :]), ops.text())
        return None
    # A raw frame: JSON-ish text from the input, answered (if at all) with id null.
    body = ops.text().encode()
    if b"shutdown" in body or b"exit" in body:
        return None  # the two messages that end a server on purpose
    wire.send_bytes(b"Content-Length: %d\r\n\r\n" % len(body) + body)
    return None


def _change(wire: Any, uri: str, version: int, change: dict[str, Any]) -> None:
    document = {"uri": uri, "version": version}
    wire.notify("textDocument/didChange", {"textDocument": document, "contentChanges": [change]})


def _judge(messages: list[dict[str, Any]]) -> None:
    for message in messages:
        error = message.get("error") or {}
        if error.get("code") == -32603:
            raise Crash(f"internal error: {json.dumps(message)[:2000]}")
        shown = message.get("params", {}).get("message", "")
        if message.get("method") == "window/showMessage" and "Error in server" in shown:
            raise Crash(f"server error: {shown[:2000]}")
