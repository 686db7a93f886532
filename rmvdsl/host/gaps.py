"""Messages a reader lost, from gaps in each publisher's sequence numbers."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


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
