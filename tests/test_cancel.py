"""The editor stops a solver stage whose text has changed: at its next solver call,
leaving nothing behind that a later check would see."""

from __future__ import annotations

import contextlib
import itertools
import threading
from pathlib import Path

import pytest

from rmvdsl.editor.workspace import Workspace
from rmvdsl.util.cache import Cache, use_cache
from rmvdsl.util.cancel import Cancelled, checkpoint, stoppable
from rmvdsl.util.deep import deep

SPEC = Path(__file__).resolve().parent.parent / "examples" / "errors" / "properties.rmv"


def _codes(workspace: Workspace) -> list[tuple[str, int]]:
    result = workspace.check(str(SPEC), solver=True)
    return sorted((d.code, d.span.start) for d in result.diagnostics)


@pytest.fixture(autouse=True)
def _default_cache_after():
    yield
    use_cache(None)


@pytest.mark.parametrize("calls", [0, 1, 3])
def test_a_stopped_stage_stops_and_the_next_check_is_whole(calls, tmp_path):
    use_cache(Cache(tmp_path / "first"))
    expected = _codes(Workspace())
    use_cache(Cache(tmp_path / "cache"))  # every question asked again
    workspace = Workspace(incremental=True)
    workspace.check(str(SPEC), solver=False)
    asked = itertools.count()
    with stoppable(lambda: next(asked) >= calls), pytest.raises(Cancelled):
        workspace.check(str(SPEC), solver=True)
    assert next(asked) == calls + 1  # stopped at checkpoint number `calls`
    assert _codes(workspace) == expected


def test_checkpoints_outside_a_stoppable_stage_do_nothing():
    """Nor in another thread while one runs: the language server's fast lane checks
    while its solver lane's stage may be stopped."""
    checkpoint()
    with stoppable(lambda: True):
        with pytest.raises(Cancelled):
            checkpoint()
        failed: list[BaseException] = []
        other = threading.Thread(target=_collect, args=(failed,))
        other.start()
        other.join()
        assert failed == []
        with pytest.raises(Cancelled):
            deep(checkpoint)  # a check's own deep stack is stopped too
    checkpoint()


def _collect(failed: list[BaseException]) -> None:
    try:
        checkpoint()
    except BaseException as error:
        failed.append(error)


def test_a_stopped_stage_leaves_nothing_for_the_collector():
    """What a stopped stage held is freed when its Cancelled is caught, not at the
    next full collection: the error handed out of the deep stack kept a cycle (the
    error, its traceback's frames, the list it was handed in), and an editor
    pausing between keys left 19 MB behind per stopped stage."""
    import gc
    import weakref

    class Held:
        pass

    held: list[weakref.ref[Held]] = []

    def stage() -> None:
        inner = Held()
        held.append(weakref.ref(inner))
        with stoppable(lambda: True):
            checkpoint()

    gc.disable()  # only reference counting frees anything now
    try:
        with contextlib.suppress(Cancelled):
            deep(stage)
        assert held and held[0]() is None
    finally:
        gc.enable()
