"""A raw JSON-RPC client for `rmv lsp` over stdio: bytes as an editor sends them,
with no library between (the edge tests, the storm and the LSP fuzz target send
what a library client would refuse to: bad params, unknown methods, broken
frames)."""

from __future__ import annotations

import io
import json
import os
import queue
import subprocess
import threading
import time
import traceback
from pathlib import Path
from typing import Any

from conftest import RMV


class InProcess:
    """`rmv lsp`'s server (rmvdsl.editor.lsp.server.build) in a thread, over two
    pipes, with what of a Popen the Wire reads: stdin, stdout, stderr, poll()."""

    def __init__(self, own_process: bool = False) -> None:
        from rmvdsl.editor.lsp.server import build

        to_server, from_client = os.pipe()
        to_client, from_server = os.pipe()
        self.stdin = os.fdopen(from_client, "wb")
        self.stdout = os.fdopen(to_client, "rb")
        self.said = io.BytesIO()  # how the thread ended, if not as asked
        self.stderr = self  # read() blocks until the server ends, as a pipe would
        self.returncode: int | None = None
        # what a test may look into (its lanes, its state); `own_process`: the
        # server tunes this interpreter's collector, as `rmv lsp` does its own
        self.server = build(own_process=own_process)

        def serve() -> None:
            code = 0
            with os.fdopen(to_server, "rb") as given, os.fdopen(from_server, "wb") as said:
                try:
                    self.server.start_io(given, said)
                except SystemExit as end:  # `exit`, as `rmv lsp` would
                    code = end.code if isinstance(end.code, int) else 1
                except BaseException:  # the server's end, whatever it was, is the report
                    code = 1
                    self.said.write(traceback.format_exc().encode())
            self.returncode = code

        self.thread = threading.Thread(target=serve, name="rmv-lsp", daemon=True)
        self.thread.start()

    def poll(self) -> int | None:
        return None if self.thread.is_alive() else self.returncode

    def read(self) -> bytes:
        self.thread.join()
        return self.said.getvalue()

    def wait(self, timeout: float | None = None) -> int:
        self.thread.join(timeout)
        if self.thread.is_alive():
            raise subprocess.TimeoutExpired("rmv lsp (in process)", timeout or 0)
        return self.returncode or 0

    def kill(self) -> None:
        self.stdin.close()  # the server reads the end of its input and stops


class Wire:
    """One server process and what it sent, read by a thread of its own."""

    def __init__(
        self,
        cwd: Path | None = None,
        in_process: bool = False,
        env: dict[str, str] | None = None,
        own_process: bool = False,
    ) -> None:
        """`rmv lsp` as its own process (with `env`, if given), or (`in_process`) the
        same server in a thread of this one: what the LSP fuzz target talks to, so
        that atheris's coverage of rmvdsl's code guides it (`own_process`: see
        InProcess)."""
        pipe = subprocess.PIPE
        self.process: Any = (
            InProcess(own_process)
            if in_process
            else subprocess.Popen(
                [*RMV, "lsp"], stdin=pipe, stdout=pipe, stderr=pipe, cwd=cwd, env=env
            )
        )
        self.inbox: queue.Queue[dict[str, Any] | None] = queue.Queue()
        self.seen: list[dict[str, Any]] = []
        self.next_id = 0
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()
        self.stderr = b""
        self.stderr_reader = threading.Thread(target=self._read_stderr, daemon=True)
        self.stderr_reader.start()

    def _read(self) -> None:
        stream = self.process.stdout
        assert stream is not None
        while True:
            length = None
            while True:
                line = stream.readline()
                if not line:
                    self.inbox.put(None)
                    return
                if line in (b"\r\n", b"\n"):
                    break
                name, _, value = line.decode("ascii").partition(":")
                if name.strip().lower() == "content-length":
                    length = int(value)
            assert length is not None, "a frame without Content-Length"
            self.inbox.put(json.loads(stream.read(length)))

    def _read_stderr(self) -> None:
        assert self.process.stderr is not None
        self.stderr = self.process.stderr.read()

    # ---- sending ----

    def send_bytes(self, data: bytes) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(data)
        self.process.stdin.flush()

    def send(self, message: dict[str, Any]) -> None:
        body = json.dumps({"jsonrpc": "2.0", **message}).encode()
        self.send_bytes(b"Content-Length: %d\r\n\r\n" % len(body) + body)

    def notify(self, method: str, params: Any) -> None:
        self.send({"method": method, "params": params})

    def request(self, method: str, params: Any) -> int:
        self.next_id += 1
        self.send({"id": self.next_id, "method": method, "params": params})
        return self.next_id

    # ---- receiving ----

    def take(self, timeout: float) -> dict[str, Any] | None:
        """The next message the server sent, None when it closed its output;
        TimeoutError after `timeout` seconds of silence."""
        try:
            message = self.inbox.get(timeout=timeout)
        except queue.Empty:
            raise TimeoutError(f"the server said nothing for {timeout} s") from None
        if message is not None:
            self.seen.append(message)
        return message

    def answer(self, number: int, timeout: float = 60.0) -> dict[str, Any]:
        """The response to request `number` (the whole message: result or error)."""
        for old in self.seen:
            if old.get("id") == number and "method" not in old:
                return old
        deadline = time.monotonic() + timeout
        while True:
            message = self.take(max(0.01, deadline - time.monotonic()))
            if message is None:
                raise EOFError(f"the server ended before answering {number}")
            if message.get("id") == number and "method" not in message:
                return message

    def call(self, method: str, params: Any, timeout: float = 60.0) -> dict[str, Any]:
        return self.answer(self.request(method, params), timeout)

    def diagnostics_until(
        self, uri: str, wanted: Any, timeout: float = 120.0, since: int = 0
    ) -> dict[str, Any]:
        """The first diagnostics published for `uri` whose params `wanted` accepts:
        among those seen from message number `since` on (`len(seen)` before the
        change that should cause them), else the next ones to come."""
        deadline = time.monotonic() + timeout
        for old in self.seen[since:]:
            if _diagnostics_of(old, uri) and wanted(old["params"]):
                return old["params"]
        while True:
            message = self.take(max(0.01, deadline - time.monotonic()))
            if message is None:
                raise EOFError("the server ended")
            if _diagnostics_of(message, uri) and wanted(message["params"]):
                return message["params"]

    # ---- the session ----

    def initialize(self, root: Path, capabilities: dict[str, Any] | None = None) -> dict[str, Any]:
        answer = self.call(
            "initialize",
            {"processId": None, "rootUri": root.as_uri(), "capabilities": capabilities or {}},
        )
        self.notify("initialized", {})
        return answer["result"]

    def open(self, path: Path, text: str, version: int = 1) -> str:
        uri = path.as_uri()
        self.notify("textDocument/didOpen", {"textDocument": {
            "uri": uri, "languageId": "rmv", "version": version, "text": text}})  # fmt: skip
        return uri

    def close(self, timeout: float = 30.0) -> int:
        """Shut the server down as an editor does; its exit code."""
        try:
            self.call("shutdown", None, timeout)
            self.notify("exit", None)
            return self.process.wait(timeout)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()


def _diagnostics_of(message: dict[str, Any], uri: str) -> bool:
    return (
        message.get("method") == "textDocument/publishDiagnostics"
        and message["params"]["uri"] == uri
    )
