"""What a node reports, independent of ROS's message classes: diagnostics
statuses, latency percentiles, and the verdict segment /rmv/verdicts carries."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

# Diagnostics levels by name (ros2.py maps them onto DiagnosticStatus's).
OK, WARN, ERROR, STALE = "ok", "warn", "error", "stale"
VERDICT_LEVELS = {"true": OK, "false": ERROR}  # unknown: stale
ALERT_LEVELS = {"OK": OK, "INFO": OK, "WARNING": WARN, "CRITICAL": ERROR}


@dataclass(frozen=True)
class Status:
    """One status of a node's DiagnosticArray: `NODE: name`."""

    node: str
    name: str
    level: str
    message: str
    values: Mapping[str, str] = field(default_factory=dict)

    @property
    def full_name(self) -> str:
        return f"{self.node}: {self.name}"


def percentiles(what: str, samples: Iterable[int]) -> dict[str, str]:
    """p50 and p99 of durations in integer nanoseconds, as diagnostics values in
    milliseconds (`what p50 (ms)`)."""
    ordered = sorted(samples)
    if not ordered:
        return {}
    found = {"p50": ordered[len(ordered) // 2], "p99": ordered[int(len(ordered) * 0.99)]}
    return {f"{what} {k} (ms)": f"{v / 1e6:.3f}" for k, v in found.items()}


def verdict_segment(record: Mapping[str, Any]) -> dict[str, Any]:
    """A verdict record as /rmv/verdicts carries it (the replay's JSON object)."""
    keys = ("property", "verdict", "from", "to", "bounds", "revised")
    return {"kind": "verdict", **{k: record[k] for k in keys if k in record}}


def fill_diagnostics(
    array: Any,
    statuses: Iterable[Status],
    classes: tuple[Any, Any],
    levels: Mapping[str, Any],
    hardware_id: str,
) -> Any:
    """Append `statuses` to a diagnostic_msgs/DiagnosticArray `array` of either ROS
    (`classes`: its DiagnosticStatus and KeyValue; `levels`: its level of each of
    ours); the array."""
    status_class, key_value = classes
    for status in statuses:
        values = [key_value(key=k, value=v) for k, v in status.values.items()]
        array.status.append(
            status_class(level=levels[status.level], name=status.full_name,
                         message=status.message, hardware_id=hardware_id, values=values)
        )  # fmt: skip
    return array
