"""A solver stage stopped from outside: the editor stops the one checking a text
that has changed since, so that it does not take the interpreter from the check of
the text the user now sees.

The condition is a context variable: it holds in the thread that set it and in the
deep-stack thread a check runs on (rmvdsl.util.deep runs it in a copy of the
caller's context), never in another lane's check. Outside `stoppable`,
`checkpoint` does nothing: `rmv check` is never stopped."""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator

_stop: contextvars.ContextVar[Callable[[], bool] | None] = contextvars.ContextVar(
    "rmv_stop", default=None
)


class Cancelled(BaseException):
    """Raised at a checkpoint once the stage's condition holds. A BaseException, as
    asyncio's CancelledError is: no `except Exception` on the way turns it into a
    diagnostic."""


@contextlib.contextmanager
def stoppable(stop: Callable[[], bool]) -> Iterator[None]:
    """Within (and in what it runs on a deep stack): every checkpoint raises
    Cancelled once `stop()` is true."""
    token = _stop.set(stop)
    try:
        yield
    finally:
        _stop.reset(token)


def checkpoint() -> None:
    """Where a stage may stop: before each solver call, between transducers and
    between properties."""
    stop = _stop.get()
    if stop is not None and stop():
        raise Cancelled
