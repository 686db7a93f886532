"""`rmv build --target kapacitor`: the thesis's rostopicmon, generated.

InfluxDB stores the variables (one measurement per spec, docs/kapacitor.md), its
continuous queries compute the value events exactly as the runtime does, and one
Kapacitor TICKscript per alert raises it. What InfluxDB and Kapacitor cannot compute
as the runtime does (boolean events, transducers, properties, events with no
window) is named in the build report, never dropped in silence.

Every file is rendered from the templates beside this module. The statements and
the scripts are trees of the dialect modules (rmvdsl/dialects/), printed there
with their one quoting rule; expressions reach them through translate.py.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from fractions import Fraction
from functools import reduce
from pathlib import Path
from typing import Any

from rmvdsl.dialects import influxql
from rmvdsl.dialects import tickscript as tick
from rmvdsl.runtime import lineproto
from rmvdsl.runtime import spec as ir
from rmvdsl.targets import ament, catkin
from rmvdsl.targets.kapacitor import dashboards
from rmvdsl.targets.kapacitor.build import (
    KAPACITOR_URL,
    LOG_FOLDER,
    Build,
    Left,
    TickAlert,
    environment,
    stored_at,
)
from rmvdsl.targets.kapacitor.collector import collector1_files, collector_files
from rmvdsl.targets.kapacitor.translate import (
    BuildError,
    Unsupported,
    influxql_expression,
    tick_expression,
)

# ---- the build ----


def _database(spec: ir.Spec) -> ir.Database:
    if spec.database is None:
        raise BuildError(
            "the kapacitor target stores the variables in InfluxDB: the spec needs a "
            "`database` block (docs/language.md)"
        )
    return spec.database


def _event_query(build: Build, event: ir.Event) -> influxql.CreateContinuousQuery:
    assert event.window is not None
    target = stored_at(build.database, build.database.default_retention, build.measurement)
    fill = None
    if event.fill.mode == "number" and event.fill.value is not None:
        fill = influxql.expression(influxql_expression(event.fill.value))
    elif event.fill.mode != "null":
        fill = event.fill.mode
    select = influxql.Select(
        columns=((influxql_expression(event.expr), event.name),),
        into=target,
        source=target,
        where=None if event.where is None else influxql_expression(event.where),
        interval=influxql.duration(event.window.interval),
        offset=influxql.duration(event.window.offset) if event.window.offset else None,
        every_tag=False,
        fill=fill,
        descending=event.order == "desc",
        limit=event.limit,
    )
    return influxql.CreateContinuousQuery(
        f"{build.spec.system.name}.{event.name}", build.database.name,
        _duration_or_none(event.resample_every), _duration_or_none(event.resample_for), select,
    )  # fmt: skip


def _duration_or_none(seconds: Fraction | None) -> str | None:
    return None if seconds is None else influxql.duration(seconds)


def _numeric_fields(spec: ir.Spec) -> dict[str, ir.ValueType]:
    found: dict[str, ir.ValueType] = {v.name: v.type for v in spec.variables}
    found.update({e.name: e.type for e in spec.events if e.kind == "value" and e.window})
    return {n: t for n, t in found.items() if t.kind in ("int", "float")}


def _downsample_query(build: Build, downsample: ir.Downsample) -> influxql.CreateContinuousQuery:
    numeric = _numeric_fields(build.spec)
    names = downsample.measurements if downsample.measurements is not None else tuple(numeric)
    for name in names:
        if name not in numeric:
            build.report.append(Left(
                f"downsample {downsample.name}: `{name}` is not a stored number "
                f"(`{downsample.aggregate}` needs one): not downsampled", downsample.origin,
            ))  # fmt: skip
    columns = tuple(
        (influxql.Call(downsample.aggregate, (influxql.Name(n),)), n) for n in names if n in numeric
    )
    if not columns:
        raise Unsupported("nothing to downsample")
    every = influxql.duration(downsample.every)
    select = influxql.Select(
        columns=columns,
        into=stored_at(build.database, downsample.into, build.measurement),
        source=stored_at(build.database, downsample.source, build.measurement),
        where=None,
        interval=every,
        offset=None,
        # `*` keeps the `topic` tag: each topic's points stay their own series.
        every_tag=True,
        fill=None,
        descending=False,
        limit=None,
    )
    return influxql.CreateContinuousQuery(
        f"{build.spec.system.name}.downsample.{downsample.name}", build.database.name,
        every, influxql.duration(downsample.lookback), select,
    )  # fmt: skip


def statements(build: Build) -> list[influxql.Statement]:
    """`influxdb.iql`: the database, its retention policies, the continuous queries."""
    database = build.database
    found: list[influxql.Statement] = [influxql.CreateDatabase(database.name)]
    for policy in database.retentions:
        shard = policy.shard_duration
        found.append(influxql.CreateRetentionPolicy(
            policy.name, database.name, influxql.duration(policy.duration), policy.replication,
            None if shard is None else influxql.duration(shard), policy.default,
        ))  # fmt: skip
    return found + list(build.queries)


def _text(value: str) -> tick.Text:
    return tick.Text(value)


def _handlers(build: Build, alert: ir.Alert) -> list[tick.Step]:
    owner, actions = alert.name, alert.actions
    handlers = []
    for action in actions:
        if isinstance(action, ir.Log):
            path = f"{LOG_FOLDER}/{build.spec.system.name}.{owner}.log"
            handlers.append(tick.Step(".", "log", (_text(path),)))
            if action.message is not None:
                build.report.append(Left(
                    f"alert {owner}: Kapacitor's log handler writes the alert's message, "
                    f"not the action's own {action.message!r}", alert.origin,
                ))  # fmt: skip
        elif isinstance(action, ir.Publish):
            build.publishes = True
            args: tuple[str, ...] = (
                "/usr/bin/env", "python3", str(build.handler_path), "--topic", action.topic
            )  # fmt: skip
            if action.message is not None:
                args += ("--message", action.message)
            handlers.append(tick.Step(".", "exec", tuple(_text(a) for a in args)))
        elif isinstance(action, ir.Post):
            handlers.append(tick.Step(".", "post", (_text(action.url),)))
        elif isinstance(action, ir.Tcp):
            handlers.append(tick.Step(".", "tcp", (_text(action.address),)))
        elif isinstance(action, ir.Exec):
            args = (action.command, *action.args)
            handlers.append(tick.Step(".", "exec", tuple(_text(a) for a in args)))
    return handlers


def _sources(spec: ir.Spec) -> dict[str, str]:
    """Which point carries each stored name: a topic's ROS name, or the event."""
    topics = {t.name: t.ros_name for t in spec.topics}
    found = {v.name: topics[v.topic] for v in spec.variables}
    found.update({e.name: e.name for e in spec.events if e.kind == "value" and e.window})
    return found


def _alert(build: Build, alert: ir.Alert) -> TickAlert:
    sources = _sources(build.spec)
    unstored = [n for n in alert.reads if n not in sources]
    if unstored:
        raise Unsupported(f"it reads {', '.join(unstored)}, which InfluxDB does not hold")
    if len({sources[n] for n in alert.reads}) > 1:
        # The runtime combines the newest value of each; a Kapacitor stream sees one
        # point at a time, and points of two sources are two points.
        raise Unsupported("it reads values of more than one topic or event")
    dbrp, raised, stored = _script(build, alert)
    return TickAlert(
        name=alert.name,
        task=task_id(build.spec, alert.name),
        file=f"tickscripts/{alert.name}.tick",
        script=(tick.statement(dbrp), tick.statement(raised), tick.statement(stored)),
    )


def _script(build: Build, alert: ir.Alert) -> tuple[tick.Dbrp, tick.Pipeline, tick.Pipeline]:
    """The task: each point carrying what the alert reads decides its level; every
    alert event is also stored (for the dashboards)."""
    database, retention = build.database.name, build.database.default_retention
    checks: list[tick.Expr] = [tick.Call("isPresent", (tick.Reference(n),)) for n in alert.reads]
    present = reduce(lambda left, right: tick.Binary("AND", left, right), checks)
    steps = [
        tick.Step("|", "from"),
        tick.Step(".", "database", (_text(database),)),
        tick.Step(".", "retentionPolicy", (_text(retention),)),
        tick.Step(".", "measurement", (_text(build.measurement),)),
        tick.Step(".", "where", (tick.Lambda(present),)),
        tick.Step("|", "alert"),
        tick.Step(".", "id", (_text(tick.go_template_text(alert.id)),)),
        tick.Step(".", "message", (_text(tick.go_template_text(alert.message)),)),
    ]
    if alert.details:
        steps.append(tick.Step(".", "details", (_text(tick.go_template_text(alert.details)),)))
    for level in alert.levels:
        condition = tick.Lambda(tick_expression(level.condition))
        steps.append(tick.Step(".", level.severity, (condition,)))
        if level.reset is not None:
            reset = tick.Lambda(tick_expression(level.reset))
            steps.append(tick.Step(".", f"{level.severity}Reset", (reset,)))
    steps += [tick.Step(".", "levelField", (_text("level"),)),
              tick.Step(".", "messageField", (_text("message"),))]  # fmt: skip
    if alert.state_changes_only:
        steps.append(tick.Step(".", "stateChangesOnly"))
    if alert.no_recoveries:
        steps.append(tick.Step(".", "noRecoveries"))
    steps += _handlers(build, alert)
    stored = (
        tick.Step("|", "influxDBOut"),
        tick.Step(".", "database", (_text(database),)),
        tick.Step(".", "retentionPolicy", (_text(retention),)),
        tick.Step(".", "measurement", (_text(build.alerts_measurement),)),
        tick.Step(".", "tag", (_text("alert"), _text(alert.name))),
    )
    return (tick.Dbrp(database, retention), tick.Pipeline("stream", tuple(steps), "raised"),
            tick.Pipeline("raised", stored))  # fmt: skip


def plan(spec: ir.Spec, handlers: Path) -> Build:
    """What the target writes for a spec, and the report of what it leaves to the
    ros2 target's monitor. `handlers`: the folder the publish handler is run from."""
    try:
        return _plan(spec, handlers)
    except (influxql.InfluxQLError, tick.TickError) as why:
        raise BuildError(str(why)) from None


def _plan(spec: ir.Spec, handlers: Path) -> Build:
    database = _database(spec)
    measurement = lineproto.measurement_name(spec)
    build = Build(
        spec, database, measurement, handlers / "publish_alert.py", f"{measurement}_alerts"
    )
    for event in spec.events:
        if event.kind == "boolean":
            build.report.append(Left(
                f"event {event.name}: a boolean event (a condition over the newest values) "
                "is not stored; transducers and properties read it in the ros2 or ros1 monitor",
                event.origin,
            ))  # fmt: skip
        elif event.window is None:
            build.report.append(Left(
                f"event {event.name}: no `group by time(...)`: a continuous query needs a "
                "window; the ros2 or ros1 monitor computes it", event.origin,
            ))  # fmt: skip
        else:
            _add_query(build, f"event {event.name}", _event_query, event, event.origin)
            if event.range is not None:
                build.report.append(Left(
                    f"event {event.name}: `range` is left out: each run of a continuous "
                    "query reads its own time range (the runtime does the same)", event.origin,
                ))  # fmt: skip
            if event.tags:
                build.report.append(Left(
                    f"event {event.name}: tags are left out of GROUP BY, as the runtime "
                    "ignores them (a ROS message is one series)", event.origin,
                ))  # fmt: skip
    for downsample in database.downsamples:
        what = f"downsample {downsample.name}"
        _add_query(build, what, _downsample_query, downsample, downsample.origin)
    for alert in spec.alerts:
        try:
            build.alerts.append(_alert(build, alert))
        except Unsupported as why:
            text = (
                f"alert {alert.name}: not a TICKscript ({why}): the ros2 or ros1 monitor raises it"
            )
            build.report.append(Left(text, alert.origin))
    for transducer in spec.transducers:
        build.report.append(Left(
            f"transducer {transducer.name}: Kapacitor has no state transducers: the "
            "collector runs it in the runtime and stores its states (for the dashboards); "
            "properties over them need the ros2 or ros1 monitor", transducer.origin,
        ))  # fmt: skip
    for prop in spec.properties:
        build.report.append(Left(
            f"property {prop.name}: an RMTLD3 property over transducer states and "
            "boolean events needs the ros2 or ros1 monitor (no stateDuration/"
            "stateCount pipeline computes it exactly)", prop.origin,
        ))  # fmt: skip
    if spec.whitelists or spec.nodes:
        first = spec.whitelists[0].origin if spec.whitelists else spec.nodes[0].origin
        build.report.append(Left("whitelists: intrusion detection reads the ROS graph: the ros2 "
                                 "or ros1 intrusion node", first))  # fmt: skip
    return build


def _add_query(
    build: Build,
    what: str,
    make: Callable[[Build, Any], influxql.CreateContinuousQuery],
    part: Any,
    origin: str,
) -> None:
    """The continuous query of an event or a downsample, or a line in the report
    saying why there is none."""
    try:
        build.queries.append(make(build, part))
    except Unsupported as why:
        build.report.append(Left(f"{what}: no continuous query ({why}): the ros2 or ros1 monitor "
                                 "computes it", origin))  # fmt: skip


def task_id(spec: ir.Spec, alert: str) -> str:
    """A Kapacitor task's id: the system's name and the alert's (both identifiers,
    so within Kapacitor's `^[-._\\p{L}0-9]+$`)."""
    return f"{spec.system.name}.{alert}"


def manifest(build: Build) -> dict[str, Any]:
    """What `rmv deploy` needs beside the files: where the servers are, which
    environment variables hold the credentials (never their values), the tasks."""
    database = build.database
    username, password = database.username, database.password
    return {
        "format": "rmvdsl.kapacitor",
        "version": 1,
        "prefix": f"{build.spec.system.name}.",
        "influx_url": database.url,
        "kapacitor_url": KAPACITOR_URL,
        "database": database.name,
        "username_env": username.env if username is not None else None,
        "password_env": password.env if password is not None else None,
        "tasks": [
            {
                "id": alert.task,
                "file": alert.file,
                "type": "stream",
            }
            for alert in build.alerts
        ],
    }


def files(spec: ir.Spec, out: Path, ros: str = "ros2") -> tuple[dict[str, str], list[Left]]:
    """Every file of the build by path relative to `out`, and the report; the
    collector is for `ros` (ros2 or ros1)."""
    build = plan(spec, out.resolve() / "handlers")
    env = environment()
    context = {"build": build, "spec": spec, "database": build.database,
               "kapacitor_url": KAPACITOR_URL}  # fmt: skip
    iql = env.get_template("influxdb.iql.j2").render(statements=statements(build), **context)
    written = {"influxdb.iql": iql}
    for alert in build.alerts:
        written[alert.file] = env.get_template("alert.tick.j2").render(alert=alert, **context)
    if build.publishes:
        written["handlers/publish_alert.py"] = env.get_template("publish_alert.py.j2").render(
            **context
        )
    written.update(dashboards.dashboard_files(build, env))
    written.update(collector1_files(build) if ros == "ros1" else collector_files(build, env))
    written["deploy.json"] = json.dumps(manifest(build), indent=2) + "\n"
    written["README.md"] = env.get_template("README.md.j2").render(
        files=sorted(written), report=build.report, **context
    )
    return written, build.report


def write(spec: ir.Spec, out: Path, ros: str = "ros2") -> tuple[list[Path], list[Left]]:
    """Write the build into `out`; the paths written and the report."""
    texts, report = files(spec, out, ros)
    return catkin.make_executable(ament.write(texts, out)), report


__all__ = ["BuildError", "Unsupported", "files", "plan", "statements", "write"]
