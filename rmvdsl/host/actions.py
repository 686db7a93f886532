"""The runtime's actions as a live node takes them: `log` to the node's logger,
`publish` a string on a topic, `exec`/`post`/`tcp` in a worker thread (never in
the thread that reads messages)."""

from __future__ import annotations

import threading
from collections.abc import Callable

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.actions import leaves_the_process, perform
from rmvdsl.runtime.engine import ActionContext

LOG_LEVELS = ("debug", "info", "warn", "error", "fatal")


class NodeActions:
    """`log(level, text)` and `publish(topic, text)` are the node's; errors of the
    actions that leave the process go to `log("error", ...)`."""

    def __init__(
        self, log: Callable[[str, str], None], publish: Callable[[str, str], None]
    ) -> None:
        self.log = log
        self.publish = publish

    def act(self, action: ir.Action, context: ActionContext) -> None:
        if isinstance(action, ir.Log):
            level = context.level if context.level in LOG_LEVELS else "error"
            self.log(level, context.message)
        elif isinstance(action, ir.Publish):
            self.publish(action.topic, context.message)
        elif leaves_the_process(action):
            threading.Thread(target=self._perform, args=(action, context), daemon=True).start()

    def _perform(self, action: ir.Action, context: ActionContext) -> None:
        error = perform(action, context.record)
        if error is not None:
            self.log("error", f"{action.TAG} action of {context.owner}: {error}")
