"""A recording's messages as the runtime takes them, read on a second core.

`readings` reads the recording, decodes each message for the fields the spec reads
and takes its reading (rmvdsl.runtime.readings): the stamp and the variables'
values, all the runtime needs of a message. That is a quarter (MCAP) to two
fifths (a ROS 1 bag) of a replay's work, and none of it depends on the runtime's
state, so `in_a_child` runs it in a forked process while this one runs the spec
(docs/replay.md, "Two processes"). The readings come through a pipe in pickled
batches of small values; the pipe's capacity holds the reader back when the
runtime falls behind, so both processes' memory stays flat in the recording's
length. The items and their order are the same either way: `readings` is the one
source of both.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import struct
import sys
import traceback
import warnings
from collections.abc import Callable, Generator, Iterator
from typing import IO, Any, NamedTuple, NoReturn

from rmvdsl.runtime.engine import seconds
from rmvdsl.runtime.readings import Readers
from rmvdsl.tools.recordings import ReplayError, damage, key, messages_in_order
from rmvdsl.tools.report.text import decimal_text

BATCH = 256  # items per pickled batch: big enough that pickling runs in C
_LENGTH = struct.Struct("<Q")  # a batch's bytes (its values may be long strings)


class Damaged(NamedTuple):
    """A message whose bytes do not decode as its type: the decoder's words."""

    reason: str


class Stopped(NamedTuple):
    """The recording cannot be read past the item's time: the rest is not read."""

    text: str


# (the connection's index in the connections read, the receipt time in ns, and the
# reading, None where the spec reads nothing of the topic, Damaged, or Stopped with
# index -1)
Item = tuple[int, int, Any]


def usable() -> bool:
    """Whether a second process pays: a second core to run it on, and fork (Linux:
    elsewhere a forked child of a threaded process is not safe)."""
    return sys.platform == "linux" and len(os.sched_getaffinity(0)) >= 2


def readings(
    reader: Any,
    connections: list[Any],
    read: set[tuple[int, int]],
    decoder_of: Callable[[Any], Callable[[bytes], Any]],
    readers: Readers,
    start: int | None,
    stop: int | None,
) -> Generator[Item, None, None]:
    """The items of the reader's messages on `connections` (those whose key is in
    `read` decoded, the others only timed) from `start` to before `stop` (ns; None:
    the recording's own ends), up to where the recording cannot be
    read any further (damaged bytes): a Stopped item says where."""
    index_of = {id(c): i for i, c in enumerate(connections)}
    decoders: list[Callable[[bytes], Any] | bool | None] = [False] * len(connections)
    last = reader.start_time
    messages = messages_in_order(reader, connections, start, stop)
    while True:
        try:  # around the reader only: an error of what follows is not the recording's
            connection, timestamp, raw = next(messages)
        except StopIteration:
            return
        except Exception as error:  # rosbags meets damaged bytes in many ways
            yield (
                -1,
                last,
                Stopped(
                    f"the recording cannot be read past {decimal_text(seconds(last))}: "
                    f"{damage(error)}; the rest of it is not checked"
                ),
            )
            return
        last = timestamp
        index = index_of[id(connection)]
        decode = decoders[index]
        if decode is False:  # the connection's first message
            wanted = key(connection) in read and connection.topic in readers.by_topic
            decode = decoders[index] = decoder_of(connection) if wanted else None
        if decode is None:  # a topic nothing reads (a whitelist's): its bytes unread
            yield index, timestamp, None
            continue
        try:
            message = decode(raw)  # type: ignore[operator]
        except Exception as error:
            yield index, timestamp, Damaged(str(error))
            continue
        yield index, timestamp, readers.reading(connection.topic, message)


def in_a_child(items: Iterator[Item]) -> Generator[Item, None, None]:
    """`items`, made by a forked child process (not started here: the generator
    runs there). Ending the iteration early ends the child. Where no process or
    pipe can be made (a limit reached), the items are made here, as on one core."""
    started = _started(items)
    if started is None:
        yield from items
        return
    pid, read_end = started
    try:
        with os.fdopen(read_end, "rb") as pipe:
            while True:
                batch = _receive(pipe)
                if batch is None:  # the end, as the child said it
                    return
                if isinstance(batch, str):
                    raise ReplayError(f"the recording's reader failed: {batch}")
                yield from batch
    finally:
        _end(pid)


def _started(items: Iterator[Item]) -> tuple[int, int] | None:
    """The child making `items` and the end of the pipe it writes them to, or None
    where either cannot be made."""
    try:
        read_end, write_end = os.pipe()
    except OSError:
        return None
    try:
        with warnings.catch_warnings():
            # Python 3.12 warns of fork in a threaded process (the commands run on
            # a thread of their own: rmvdsl.util.deep): the child may need a lock
            # that another thread held. This one takes none that Python does not
            # reset at fork (the allocator's, the import lock, logging's): it reads,
            # decodes, pickles and writes to its pipe, then ends without the
            # parent's exit.
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
    except OSError:
        os.close(read_end)
        os.close(write_end)
        return None
    if pid == 0:
        _child(items, read_end, write_end)
    os.close(write_end)
    return pid, read_end


def _child(items: Iterator[Item], read_end: int, write_end: int) -> NoReturn:
    status = 0
    try:
        os.close(read_end)
        # Ctrl-C stops the parent, which ends this process: not a second traceback.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        with os.fdopen(write_end, "wb", buffering=1 << 16) as pipe:
            try:
                batch: list[Item] = []
                for item in items:
                    batch.append(item)
                    if len(batch) == BATCH:
                        _send(pipe, batch)
                        batch = []
                _send(pipe, batch)
                _send(pipe, None)
            except BrokenPipeError:
                raise  # the parent stopped reading: nothing to say
            except BaseException as error:
                _send(pipe, "".join(traceback.format_exception_only(error)).strip())
    except BaseException:
        status = 1
    finally:
        os._exit(status)  # neither the parent's atexit handlers nor its buffers


def _send(pipe: IO[bytes], payload: object) -> None:
    data = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
    pipe.write(_LENGTH.pack(len(data)))
    pipe.write(data)


def _receive(pipe: IO[bytes]) -> Any:
    head = pipe.read(_LENGTH.size)
    if len(head) < _LENGTH.size:
        raise ReplayError("the recording's reader process ended before the recording did")
    (length,) = _LENGTH.unpack(head)
    data = pipe.read(length)
    if len(data) < length:
        raise ReplayError("the recording's reader process ended before the recording did")
    return pickle.loads(data)


def _end(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError):  # a child that ended: a zombie till waited
        os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
