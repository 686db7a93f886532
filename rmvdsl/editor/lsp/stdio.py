"""The server's stdin, read by a thread of its own in whole chunks.

pygls reads stdin through its thread pool, one `readline` or `read` a hop: three
hops a message (its header, the blank line, its body), each a handoff of the
interpreter's lock between the pool's thread and the event loop. While a
keystroke's check runs in another thread, each handoff waits for the check to
yield the lock: a completion request sent beside a check took 33 ms at the
median instead of 9 (2,000 lines). Here one thread reads whatever has arrived
(a message, or several) and wakes the loop once; pygls's message loop
(`pygls.io_.run_async`) reads its lines and bodies from that buffer, with the
meaning of a file's `readline` and `read(n)` (short at the end of the input).
"""

from __future__ import annotations

import asyncio
import logging
import os
import threading
from collections.abc import Callable
from typing import Any, BinaryIO

from pygls.io_ import StdoutWriter, run_async
from pygls.server import JsonRPCServer

CHUNK = 1 << 16  # bytes read at once: a keystroke's message is a few hundred


def serve(server: JsonRPCServer, stdin: BinaryIO, stdout: BinaryIO) -> None:
    """pygls's `start_io` (its message loop, writer and shutdown), reading `stdin`
    with ChunkedStdin. Returns when the input ends; the client's `exit` ends it
    with SystemExit, its code 0 after `shutdown` and 1 without, as LSP asks
    (pygls's own `start_io` swallows it: the process ended with 0 either way)."""
    # pygls's shutdown (the `exit` notification's) sets this to end the loop.
    stop = server._stop_event = threading.Event()
    server.protocol.set_writer(StdoutWriter(stdout))

    async def messages() -> None:
        asyncio.get_running_loop().set_exception_handler(_cancelled_quietly)
        await run_async(
            stop_event=stop,
            reader=ChunkedStdin(stdin),
            protocol=server.protocol,
            logger=logging.getLogger("pygls.server"),
            error_handler=server.report_server_error,
        )

    try:
        asyncio.run(messages())
    except (BrokenPipeError, KeyboardInterrupt):  # the client went away, or ^C
        pass
    finally:
        server.shutdown()


def _cancelled_quietly(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
    """The loop's report of an error in a callback, but for a cancelled task's: at
    `exit` the checks still waiting (a debounce, a solver stage) are cancelled, and
    pygls's callback on each raised CancelledError into the log (a traceback)."""
    if not isinstance(context.get("exception"), asyncio.CancelledError):
        loop.default_exception_handler(context)


class ChunkedStdin:
    """pygls's `AsyncReader` over a binary stream, read by a daemon thread."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self._buffer = bytearray()
        self._ended = False
        self._arrived: asyncio.Future[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

    async def readline(self) -> bytes:
        """Up to and including the next newline; the rest at the end of the input."""
        searched = 0  # a long line arriving in many chunks is searched once
        while True:
            end = self._buffer.find(b"\n", searched)
            if end >= 0:
                return self._take(end + 1)
            if self._ended:
                return self._take(len(self._buffer))
            searched = len(self._buffer)
            await self._more()

    async def readexactly(self, n: int) -> bytes:
        """`n` bytes, or fewer at the end of the input (as `read(n)` of a file)."""
        while len(self._buffer) < n and not self._ended:
            await self._more()
        return self._take(min(n, len(self._buffer)))

    def _take(self, n: int) -> bytes:
        taken = bytes(self._buffer[:n])
        del self._buffer[:n]
        return taken

    async def _more(self) -> None:
        if self._loop is None:  # started by the first read, on the loop that reads
            self._loop = asyncio.get_running_loop()
            threading.Thread(target=self._read_all, name="rmv-stdin", daemon=True).start()
        self._arrived = self._loop.create_future()
        await self._arrived

    def _read_all(self) -> None:
        """The thread: read until the input ends, handing each chunk to the loop."""
        read = _chunk_reader(self._stream)
        while True:
            try:
                chunk = read()
            except (OSError, ValueError):  # closed under us: the input has ended
                chunk = b""
            if not self._hand_over(chunk):
                return
            if not chunk:
                return

    def _hand_over(self, chunk: bytes) -> bool:
        """Give the loop a chunk (b"": the end); False once the loop has closed."""
        assert self._loop is not None
        try:
            self._loop.call_soon_threadsafe(self._received, chunk)
        except RuntimeError:  # the loop closed: the server is stopping
            return False
        return True

    def _received(self, chunk: bytes) -> None:
        if chunk:
            self._buffer += chunk
        else:
            self._ended = True
        if self._arrived is not None and not self._arrived.done():
            self._arrived.set_result(None)


def _chunk_reader(stream: BinaryIO) -> Callable[[], bytes]:
    """What has arrived, at most CHUNK bytes (blocks until something has; b"" at
    the end): the descriptor's `read`, else the stream's own `read1` or `read`."""
    try:
        descriptor = stream.fileno()
    except (OSError, ValueError, AttributeError):  # no descriptor (a test's stream)
        read1 = getattr(stream, "read1", None)
        if read1 is not None:
            return lambda: bytes(read1(CHUNK))
        return lambda: bytes(stream.read(CHUNK))
    return lambda: os.read(descriptor, CHUNK)
