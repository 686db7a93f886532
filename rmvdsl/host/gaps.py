"""Messages a reader lost (from gaps in each publisher's sequence numbers), could
not read (`Undecodable`), or never gets (publishers of another type: `TypeWatch`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from rmvdsl.host.status import OK, WARN, Status


@dataclass(frozen=True)
class Undecodable:
    """In place of a message the node could not decode (or that is not of the
    spec's type): fed to the runtime as damaged input, in its turn."""

    reason: str


MISSING_KEPT = 10_000  # sequence numbers of missing messages remembered per publisher


class Gaps:
    """rmw's `publication_sequence_number` per topic and publisher gid: a jump of
    more than one is the number of messages lost between two read. A message that
    comes after a later one (Fast DDS sends a large message on a flow of its own)
    was counted lost when the later one came: it is found again."""

    def __init__(self) -> None:
        self.newest: dict[tuple[str, Any], int] = {}
        self.missing: dict[tuple[str, Any], set[int]] = {}

    def lost(self, topic: str, info: Mapping[str, Any]) -> int:
        """How many messages of this one's publisher went missing just before it;
        -1 when this one is a message counted missing before (found again)."""
        sequence = info.get("publication_sequence_number")
        if not sequence:
            return 0
        publisher = (topic, (info.get("publisher_gid") or {}).get("data"))
        newest = self.newest.get(publisher)
        if newest is not None and sequence <= newest:
            missing = self.missing.get(publisher, set())
            if sequence in missing:
                missing.discard(sequence)
                return -1
            return 0
        self.newest[publisher] = sequence
        if newest is None or sequence == newest + 1:
            return 0
        missing = self.missing.setdefault(publisher, set())
        missing.update(range(max(newest + 1, sequence - MISSING_KEPT), sequence))
        if len(missing) > 2 * MISSING_KEPT:  # only the newest can still come
            self.missing[publisher] = {s for s in missing if s >= sequence - MISSING_KEPT}
        return int(sequence - newest - 1)


class TypeWatch:
    """Publishers on the spec's topics that send another type than the spec reads.
    ROS 2 never delivers their messages to the monitor's reader (DDS matches
    readers and writers by type), so without this they would be silent input."""

    def __init__(self, node: str, expected: dict[str, str]) -> None:
        self.node = node
        self.expected = expected  # ROS name -> the type the spec reads
        self.warned: set[tuple[str, str, str]] = set()

    def look(self, publishers: list[tuple[str, str, str]]) -> tuple[Status, list[str]]:
        """`publishers`: (ROS name, node, type) of each publisher on the spec's
        topics. The status, and a warning for each newly seen."""
        others = sorted(p for p in publishers if p[2] != self.expected.get(p[0], p[2]))
        said = [
            f"{topic}: {kind} published by {node}, the spec reads {self.expected[topic]}: "
            "its messages never reach the monitor"
            for topic, node, kind in others
            if (topic, node, kind) not in self.warned
        ]
        self.warned.update(others)
        text = "; ".join(f"{kind} from {node} on {topic}" for topic, node, kind in others)
        values = {"publishers of another type": str(len(others))}
        status = Status(self.node, "topic types", WARN if others else OK,
                        text or "every publisher sends the spec's types", values)  # fmt: skip
        return status, said
