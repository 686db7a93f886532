"""Messages a reader lost (from gaps in each publisher's sequence numbers) or
could not read (`Undecodable`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Undecodable:
    """In place of a message the node could not decode (or that is not of the
    spec's type): fed to the runtime as damaged input, in its turn."""

    reason: str


class Gaps:
    """rmw's `publication_sequence_number` per topic and publisher gid: a jump of
    more than one is the number of messages lost between two read."""

    def __init__(self) -> None:
        self.newest: dict[tuple[str, Any], int] = {}

    def lost(self, topic: str, info: Mapping[str, Any]) -> int:
        """How many messages of this one's publisher went missing just before it."""
        sequence = info.get("publication_sequence_number")
        if not sequence:
            return 0
        publisher = (topic, (info.get("publisher_gid") or {}).get("data"))
        newest = self.newest.get(publisher)
        if newest is None or sequence > newest:
            self.newest[publisher] = sequence
        if newest is not None and sequence > newest + 1:
            return int(sequence - newest - 1)
        return 0
