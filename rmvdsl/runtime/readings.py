"""What the runtime takes of a message: its stamp (on a `time = header` topic) and
the value of each variable read of its topic.

A reading is a pure function of the message, apart from the runtime's state, so a
host may take it where the message is decoded, in another process (the replay's
reader, rmvdsl.tools.read_ahead), and hand the runtime only the reading: small
values, not the message. `Runtime.message` takes the reading in place; either way
the runtime does the same with it (docs/runtime.md, "The whole spec").
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from rmvdsl.runtime import fields
from rmvdsl.runtime import spec as ir

# (the stamp: integer ns, a FieldError where it does not read, None on a topic
# timed by receipt; per variable of the topic: its value, MISSING, or a FieldError)
Reading = tuple[int | fields.FieldError | None, tuple[Any, ...]]


class Readers:
    """The readings of every topic a spec reads (`skip`: variables the input
    cannot give, as the replay found them)."""

    def __init__(self, spec: ir.Spec, skip: Iterable[str] = ()) -> None:
        topic_names = {t.name: t.ros_name for t in spec.topics}
        skipped = frozenset(skip)
        # per topic, its variables and their readers (None: skipped by a live host's
        # `skip`; kept in place, so a reading taken before still lines up)
        self.by_topic: dict[str, list[tuple[ir.Variable, Callable[[Any], Any] | None]]] = {}
        for variable in spec.variables:
            variables = self.by_topic.setdefault(topic_names[variable.topic], [])
            if variable.name not in skipped:
                variables.append((variable, fields.reader(variable)))
        self.stamped = fields.stamped_topics(spec.topics)
        self._reads = {topic: _reads(variables) for topic, variables in self.by_topic.items()}

    def skip(self, topic: str, names: Iterable[str]) -> list[ir.Variable]:
        """From now on, `names` of `topic` are not read: the variables newly so."""
        wanted = frozenset(names)
        variables = self.by_topic.get(topic, [])
        newly = [v for v, read in variables if read is not None and v.name in wanted]
        if newly:
            variables[:] = [(v, None if v.name in wanted else read) for v, read in variables]
            self._reads[topic] = _reads(variables)
        return newly

    def reading(self, topic: str, message: Any) -> Reading | None:
        """The reading of a message of `topic`; None where the spec reads nothing
        of the topic (its message may be None: it was not decoded)."""
        reads = self._reads.get(topic)
        if reads is None:
            return None
        stamp: int | fields.FieldError | None = None
        if topic in self.stamped:
            try:
                stamp = fields.stamp(message)
            except fields.FieldError as error:
                return error, ()  # the message is dropped: nothing else is read
        try:
            return stamp, reads[0](message)
        except fields.FieldError:  # said per variable: read each again (readers are pure)
            return stamp, tuple([_read(read, message) for read in reads[1]])


Reads = tuple[Callable[[Any], tuple[Any, ...]], tuple[Callable[[Any], Any], ...]]


def _reads(variables: list[tuple[ir.Variable, Callable[[Any], Any] | None]]) -> Reads:
    """A topic's readers, and one function of them all: a message's values in one
    call and one tuple, as every message of the topic needs them."""
    each = tuple(read or _unread for _, read in variables)
    calls = "".join(f"read{i}(message), " for i in range(len(each)))
    namespace: dict[str, Any] = {f"read{i}": read for i, read in enumerate(each)}
    exec(f"def read_all(message):\n    return ({calls})\n", namespace)  # names made here
    return namespace["read_all"], each


def _unread(message: Any) -> None:
    """A skipped variable's reader: the runtime reads none of its values."""


def _read(read: Callable[[Any], Any], message: Any) -> Any:
    try:
        return read(message)
    except fields.FieldError as error:
        return error
