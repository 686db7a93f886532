"""Python's cyclic garbage collector, set for a run over a stream of messages or
samples (`rmv replay`, `rmv eval`).

Such a run makes a few short-lived containers per input (items, rows, records)
and keeps almost none: reference counting frees them, yet by default the
collector walks the young generation after every 700 net allocations. Measured
on a replay of 100,000 messages (benchmarks/bench_replay.py's recording, timed
by gc.callbacks), the collector ran 872 times for 176 ms, 7% of the run's CPU; with a
young generation of 10,000, 28 times for 15 ms. What it can hold back is at
most that many objects of cyclic garbage (about a megabyte).
"""

from __future__ import annotations

import contextlib
import gc
import threading
from collections.abc import Iterator

YOUNG = 10_000  # net allocations between two walks of the young generation

# Runs under way in this process (a Dask worker runs several replays in threads):
# the first sets the threshold, the last puts back what the first found.
_lock = threading.Lock()
_running = 0
_before = gc.get_threshold()


@contextlib.contextmanager
def for_streams() -> Iterator[None]:
    """The collector set for a run over a stream, and as it was after it (a
    command run in-process, by a test or a server, leaves it as it found it)."""
    global _running, _before
    with _lock:
        if _running == 0:
            _before = gc.get_threshold()
            gc.set_threshold(YOUNG, *_before[1:])
        _running += 1
    try:
        yield
    finally:
        with _lock:
            _running -= 1
            if _running == 0:
                gc.set_threshold(*_before)
