"""What one build of the kapacitor target holds (the plan: queries, alerts, the report
of what it leaves to the ROS monitors) and the templates' environment."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import jinja2

from rmvdsl.dialects import influxql
from rmvdsl.runtime import spec as ir
from rmvdsl.targets import ament

# The file every alert handler that writes a log appends to (Kapacitor's `.log`).
LOG_FOLDER = "/var/log/kapacitor"


KAPACITOR_URL = "http://127.0.0.1:9092"  # Kapacitor's own default


@dataclass(frozen=True)
class TickAlert:
    name: str
    task: str  # the Kapacitor task's id
    file: str
    script: tuple[str, str, str]  # dbrp, the alert's pipeline, the one storing its events


@dataclass
class Build:
    spec: ir.Spec
    database: ir.Database
    measurement: str
    handler_path: Path
    alerts_measurement: str
    queries: list[influxql.CreateContinuousQuery] = field(default_factory=list)
    alerts: list[TickAlert] = field(default_factory=list)
    report: list[Left] = field(default_factory=list)
    publishes: bool = False


class Left(str):
    """A line of the report: a part of the spec this target leaves to the ros2
    monitor, and where the spec declares it (`rmv check --target` points there)."""

    origin: str

    def __new__(cls, text: str, origin: str) -> Left:
        line = super().__new__(cls, text)
        line.origin = origin
        return line


def stored_at(database: ir.Database, retention: str, measurement: str) -> influxql.Measurement:
    return influxql.Measurement(database.name, retention, measurement)


def environment() -> jinja2.Environment:
    """This target's templates (and, for the collector, the ros2 target's), with
    the quoting filters of both."""
    env = ament.environment(__package__ or "")
    env.filters["ident"] = influxql.identifier
    env.filters["iql"] = influxql.statement
    return env
