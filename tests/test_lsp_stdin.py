"""The language server's stdin (rmvdsl.editor.lsp.stdio): read by a thread of its
own in whole chunks, with the meaning of a file's `readline` and `read(n)` for
any bytes in any chunks; and `rmv lsp` served over it, messages split and
batched as pipes deliver them, ending with LSP's exit codes."""

from __future__ import annotations

import asyncio
import io
import itertools
import json
import os
import threading
import time
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st
from lsp_wire import Wire

from rmvdsl.editor.lsp.stdio import ChunkedStdin


class _Chunks(io.RawIOBase):
    """A stream with no descriptor that hands out the given chunks, one a read."""

    def __init__(self, chunks: list[bytes]) -> None:
        self.chunks = list(chunks)

    def fileno(self) -> int:
        raise OSError("no descriptor")

    def read1(self, size: int = -1) -> bytes:
        return self.chunks.pop(0) if self.chunks else b""


def _replay(reader: ChunkedStdin, reads: list[int]) -> list[bytes]:
    """Each read: -1 a readline, else a readexactly of that many bytes."""

    async def run() -> list[bytes]:
        return [await (reader.readline() if n < 0 else reader.readexactly(n)) for n in reads]

    return asyncio.run(run())


def _as_a_file(data: bytes, reads: list[int]) -> list[bytes]:
    stream = io.BytesIO(data)
    return [stream.readline() if n < 0 else stream.read(n) for n in reads]


_LINES = st.lists(
    st.sampled_from([b"Content-Length: 12\r\n", b"\r\n", b"\n", b"{}", b"x" * 70_000, b"\xff"]),
    max_size=12,
).map(b"".join)


@settings(max_examples=200, deadline=None)
@given(data=_LINES, cuts=st.lists(st.integers(0, 80_000)), reads=st.lists(st.integers(-1, 40)))
def test_any_chunks_read_as_a_file_reads_the_same_bytes(
    data: bytes, cuts: list[int], reads: list[int]
):
    """Lines, bodies and the end of the input, wherever the chunks are cut (a
    line longer than a chunk, a message split or several in one chunk)."""
    bounds = sorted({0, len(data), *(c for c in cuts if c < len(data))})
    chunks = [data[a:b] for a, b in itertools.pairwise(bounds)]
    reads = [*reads, -1, -1]  # and past the end: b"" as a file gives
    assert _replay(ChunkedStdin(_Chunks(chunks)), reads) == _as_a_file(data, reads)


def test_a_pipe_written_in_pieces_is_read_whole():
    """A real descriptor: a message arriving in three writes, with pauses."""
    body = json.dumps({"jsonrpc": "2.0", "method": "x", "params": {"a": "é" * 5000}}).encode()
    frame = b"Content-Length: %d\r\n\r\n" % len(body) + body
    read_end, write_end = os.pipe()

    def write() -> None:
        with os.fdopen(write_end, "wb", buffering=0) as out:
            for piece in (frame[:7], frame[7:3000], frame[3000:]):
                out.write(piece)
                time.sleep(0.05)

    writer = threading.Thread(target=write)
    writer.start()
    with os.fdopen(read_end, "rb") as given:
        got = _replay(ChunkedStdin(given), [-1, -1, len(body), -1])
    writer.join()
    assert got == [b"Content-Length: %d\r\n" % len(body), b"\r\n", body, b""]


def test_the_server_reads_stdin_without_pygls_thread_pool(tmp_path: Path):
    """pygls read stdin on its thread pool, three hops a message, each waiting for a
    running check to let go of the interpreter: a completion beside a check took
    33 ms at the median, 9 ms alone (benchmarks/bench_lsp.py). The server reads it
    on a thread of its own: pygls's pool is never made."""
    wire = Wire(in_process=True)
    try:
        wire.initialize(tmp_path)
        spec = tmp_path / "a.rmv"
        uri = wire.open(spec, 'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\n')
        wire.diagnostics_until(uri, lambda params: True)
        assert wire.process.server._thread_pool is None
        assert wire.close() == 0
    finally:
        wire.process.kill()


def test_messages_batched_and_split_are_all_answered_and_exit_codes_follow_lsp(
    tmp_path: Path,
):
    """Several messages in one write, one split mid-header and mid-body across
    writes; `exit` after `shutdown` ends the process with 0, and without it with 1
    (LSP's rule: pygls's own start_io swallowed the exit, giving 0 either way).
    Frames that are not JSON, not UTF-8 or of params of the wrong shape get their
    answers and leave no traceback on stderr (pygls logged one for each)."""

    def raw(body: bytes) -> bytes:
        return b"Content-Length: %d\r\n\r\n" % len(body) + body

    def frame(message: dict[str, object]) -> bytes:
        return raw(json.dumps({"jsonrpc": "2.0", **message}).encode())

    spec = tmp_path / "a.rmv"
    text = 'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent E when V > 1\n'
    spec.write_text(text, encoding="utf-8")
    opened = {"uri": spec.as_uri(), "languageId": "rmv", "version": 1, "text": text}
    position = {"textDocument": {"uri": spec.as_uri()}, "position": {"line": 2, "character": 14}}
    for shut_down, code in ((True, 0), (False, 1)):
        wire = Wire(cwd=tmp_path)
        try:
            init = {"processId": None, "rootUri": tmp_path.as_uri(), "capabilities": {}}
            batch = frame({"id": 1, "method": "initialize", "params": init})
            batch += frame({"method": "initialized", "params": {}})
            batch += frame({"method": "textDocument/didOpen", "params": {"textDocument": opened}})
            batch += raw(b'{"jsonrpc": "2.0", "id": 7, "meth') + raw(b"\xff\xfe")
            batch += frame({"method": "textDocument/didChange", "params": {"x": 1}})
            batch += frame({"id": 8, "method": "textDocument/hover", "params": {}})
            wire.send_bytes(batch)
            hover = frame({"id": 2, "method": "textDocument/hover", "params": position})
            for piece in (hover[:9], hover[9:40], hover[40:]):
                wire.send_bytes(piece)
                time.sleep(0.1)
            assert wire.answer(1)["result"]["capabilities"]
            assert "V" in json.dumps(wire.answer(2)["result"])
            assert wire.answer(8)["error"]["code"] == -32602  # invalid params
            if shut_down:
                wire.answer(wire.request("shutdown", None))
            wire.notify("exit", None)
            assert wire.process.wait(30) == code
            wire.stderr_reader.join(30)
            said = wire.stderr.decode(errors="replace")
            assert "Traceback" not in said and "Unable to" not in said, said
        finally:
            if wire.process.poll() is None:
                wire.process.kill()
                wire.process.wait()
