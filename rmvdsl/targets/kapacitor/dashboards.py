"""Dashboards of a spec's stored data, for Grafana and for Chronograf: one panel per
topic with its numeric variables, a table of the newest value of its boolean and
text variables, one panel per value event, the states the collector's runtime
entered, and the alerts Kapacitor raised. The
queries are the same for both tools; each has its own placeholders for the
dashboard's time range and the group-by interval."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import jinja2

from rmvdsl.dialects import influxql
from rmvdsl.runtime import lineproto
from rmvdsl.runtime import spec as ir
from rmvdsl.targets.kapacitor.build import Build, stored_at

# Marks, in a query, where a tool puts its time range and its interval.
TIME_RANGE, INTERVAL = "\x00TIME\x00", "\x00INTERVAL\x00"
GRAFANA = {TIME_RANGE: "$timeFilter", INTERVAL: "$__interval"}
CHRONOGRAF = {
    TIME_RANGE: "time > :dashboardTime: AND time < :upperDashboardTime:",
    INTERVAL: ":interval:",
}


@dataclass(frozen=True)
class Panel:
    title: str
    kind: str  # timeseries | table
    query: str  # with TIME_RANGE and INTERVAL marks

    def for_tool(self, placeholders: dict[str, str]) -> str:
        query = self.query
        for mark, text in placeholders.items():
            query = query.replace(mark, text)
        return query


@dataclass(frozen=True)
class Sources:
    """Where the data is (quoted `db.rp.measurement`) and the quoting functions."""

    points: str
    alerts: str
    states: str
    ident: Callable[[str], str]
    string: Callable[[str], str]


def _topic_panels(spec: ir.Spec, topic: ir.Topic, sources: Sources) -> list[Panel]:
    ident = sources.ident
    variables = [v for v in spec.variables if v.topic == topic.name]
    where = f"{ident('topic')} = {sources.string(topic.ros_name)} AND {TIME_RANGE}"
    out = []
    numbers = [v.name for v in variables if v.type.kind in ("int", "float")]
    if numbers:
        columns = ", ".join(f"mean({ident(n)}) AS {ident(n)}" for n in numbers)
        query = (f"SELECT {columns} FROM {sources.points} WHERE {where} "
                 f"GROUP BY time({INTERVAL}) fill(none)")  # fmt: skip
        out.append(Panel(f"{topic.name} ({topic.ros_name})", "timeseries", query))
    others = [v.name for v in variables if v.type.kind not in ("int", "float")]
    if others:
        columns = ", ".join(f"last({ident(n)}) AS {ident(n)}" for n in others)
        query = f"SELECT {columns} FROM {sources.points} WHERE {where}"
        out.append(Panel(f"{topic.name}: newest values", "table", query))
    return out


def panels(spec: ir.Spec, sources: Sources) -> list[Panel]:
    ident = sources.ident
    out = [p for topic in spec.topics for p in _topic_panels(spec, topic, sources)]
    for event in spec.events:
        if event.kind == "value" and event.window is not None:
            query = f"SELECT {ident(event.name)} FROM {sources.points} WHERE {TIME_RANGE}"
            out.append(Panel(f"event {event.name}", "timeseries", query))
    if spec.transducers:
        query = (f"SELECT {ident('state')} FROM {sources.states} WHERE {TIME_RANGE} "
                 f"GROUP BY {ident('transducer')}")  # fmt: skip
        out.append(Panel("states", "table", query))
    if spec.alerts:
        query = (f"SELECT {ident('level')}, {ident('message')} FROM {sources.alerts} "
                 f"WHERE {TIME_RANGE} GROUP BY {ident('alert')}")  # fmt: skip
        out.append(Panel("alerts", "table", query))
    return out


def dashboard_files(build: Build, env: jinja2.Environment) -> dict[str, str]:
    """A Grafana dashboard and a Chronograf dashboard export over the stored data."""
    database = build.database
    sources = Sources(
        points=influxql.measurement(
            stored_at(database, database.default_retention, build.measurement)
        ),
        alerts=influxql.measurement(
            stored_at(database, database.default_retention, build.alerts_measurement)
        ),
        states=influxql.measurement(
            stored_at(
                database, database.default_retention, lineproto.states_measurement(build.spec)
            )
        ),
        ident=influxql.identifier,
        string=influxql.string,
    )
    found = panels(build.spec, sources)
    name = build.spec.system.name
    context = {"spec": build.spec, "panels": found, "title": build.spec.system.title or name}
    uid = "rmv-" + re.sub(r"[^A-Za-z0-9_-]", "-", name)[:36]
    return {
        "dashboards/grafana.json": env.get_template("grafana.json.j2").render(
            uid=uid, placeholders=GRAFANA, **context
        ),
        "dashboards/chronograf.json": env.get_template("chronograf.json.j2").render(
            placeholders=CHRONOGRAF, **context
        ),
    }
