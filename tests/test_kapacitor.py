"""`rmv build --target kapacitor`, proven on a real InfluxDB 1.x (Debian's influxd,
started here on 127.0.0.1) and against Kapacitor's documented TICKscript grammar
(tests/kapacitor/tickscript.py; Kapacitor itself is not installable here).

- every continuous query of every example is created on influxd, and its SELECT
  runs through EXPLAIN (CREATE alone accepts queries that fail on every run);
- the continuous queries compute what the runtime computes: the worked example of
  every function in docs/runtime.md, and the braking recording through abs.rmv,
  written as the collector writes it (rmvdsl/runtime/lineproto.py), run as
  InfluxDB's continuous querier schedules the runs; same windows, fill and values;
- hostile names and strings stay data in InfluxQL, line protocol and TICKscript.
"""

from __future__ import annotations

import base64
import dataclasses
import json
import math
import os
import random
import re
import subprocess
import sys
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest
from conftest import EXAMPLES, FIXTURES, ROOT
from influx.server import Influxd
from kapacitor import tickscript
from kapacitor.server import Server as KapacitorServer
from test_functions import EXAMPLES as WORKED
from test_functions import INPUT as WORKED_INPUT

from rmvdsl.check import check
from rmvdsl.dialects import influxql
from rmvdsl.dialects import tickscript as tick
from rmvdsl.ir import lower
from rmvdsl.runtime import influx, lineproto
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Runtime
from rmvdsl.targets import kapacitor
from rmvdsl.tools.recordings import open_reader, plan
from rmvdsl.tools.replay import replay

NS = 10**9
CARLA = EXAMPLES / "carla"
BRAKING = CARLA / "recordings" / "braking_mcap"
SPECS = [CARLA / "abs.rmv", EXAMPLES / "gazebo" / "prius_platoon.rmv"]


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Influxd]:
    influxd = Influxd(tmp_path_factory.mktemp("influxd"))
    yield influxd
    influxd.stop()


def _spec(path: Path) -> ir.Spec:
    result = check(str(path))
    assert not result.errors, [str(d) for d in result.errors]
    return lower(result)


def _spec_text(text: str, tmp_path: Path, name: str = "spec.rmv") -> ir.Spec:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return _spec(path)


def _build(spec: ir.Spec, tmp_path: Path) -> dict[str, str]:
    texts, _ = kapacitor.files(spec, tmp_path / "out")
    return texts


# ---- InfluxQL: statements, continuous queries, their runs ----

_CQ = re.compile(
    r'CREATE CONTINUOUS QUERY (?P<name>"(?:\\.|[^"\\])*") ON (?P<db>"(?:\\.|[^"\\])*")\n'
    r"(?:RESAMPLE[^\n]*\n)?BEGIN\n(?P<body>.*?)\nEND;",
    re.S,
)


statements = influxql.split
_unquote = influxql.unquote


def continuous_queries(iql: str) -> dict[str, str]:
    """Each continuous query's name and its SELECT ... INTO (without BEGIN/END)."""
    return {_unquote(m.group("name")): m.group("body") for m in _CQ.finditer(iql)}


def in_range(body: str, start: int, end: int) -> str:
    """The SELECT as the continuous querier runs it over [start, end)."""
    bounds = f"time >= {start} AND time < {end}"
    lines = body.splitlines()
    for index, line in enumerate(lines):
        if line.strip().startswith("WHERE "):
            lines[index] = f"  WHERE ({line.strip()[6:]}) AND {bounds}"
            return "\n".join(lines)
        if line.strip().startswith("GROUP BY "):
            return "\n".join([*lines[:index], f"  WHERE {bounds}", *lines[index:]])
    raise AssertionError(f"no GROUP BY in {body}")


def without_into(body: str) -> str:
    return "\n".join(line for line in body.splitlines() if not line.strip().startswith("INTO "))


def run_queries(server: Influxd, spec: ir.Spec, iql: str, first: int, last: int) -> int:
    """Every run InfluxDB's continuous querier makes over data from `first` to
    `last` (ns), in its order: at each scheduled time, the queries in the order
    they were created. The number of runs."""
    bodies = continuous_queries(iql)
    events = {f"{spec.system.name}.{e.name}": e for e in spec.events if e.window is not None}
    runs: list[tuple[int, int, str, influx.Run]] = []
    for order, (name, body) in enumerate(bodies.items()):
        if name not in events:
            continue  # a downsample
        query = influx.WindowedQuery(events[name])
        now = query.first_run(first)
        while True:
            run = query.run_at(now)
            if run.start > last:
                break
            if run.end > run.start:
                runs.append((now, order, body, run))
            now += query.every
    for _, _, body, run in sorted(runs, key=lambda r: (r[0], r[1])):
        server.query(in_range(body, run.start, run.end), spec.database.name)  # type: ignore[union-attr]
    return len(runs)


def stored(server: Influxd, spec: ir.Spec, name: str, before: int) -> list[tuple[int, Any]]:
    """The points of a field in the measurement, before a time."""
    database = spec.database
    assert database is not None
    target = influxql.measurement(
        influxql.Measurement(database.name, database.default_retention, spec.system.name)
    )
    field = influxql.identifier(name)
    rows = server.points(f"SELECT {field} FROM {target} WHERE time < {before}", database.name)
    return [(int(t), v) for t, v in rows]


# Go's math package and C's libm may round these differently in the last bit
# (docs/runtime.md says so); everything else must be exact.
TRANSCENDENTAL = re.compile(r"\b(log2?|log10|ln|exp|pow|sin|cos|tan|asin|acos|atan2?)\(")


def _same(actual: Any, expected: Any, ulps: int = 0) -> bool:
    """InfluxDB's JSON writes a float with no fraction as an integer (1.0 as 1)."""
    if isinstance(expected, float):
        if not isinstance(actual, (int, float)):
            return False
        if float(actual) == expected:
            return True
        return ulps > 0 and abs(float(actual) - expected) <= ulps * math.ulp(expected)
    return actual == expected and type(actual) is type(expected)


def _fresh_schema(server: Influxd, spec: ir.Spec, tmp_path: Path) -> str:
    """The build's influxdb.iql, applied to a database dropped first."""
    iql = _build(spec, tmp_path)["influxdb.iql"]
    assert spec.database is not None
    server.query(f"DROP DATABASE {influxql.identifier(spec.database.name)}")
    for statement in statements(iql):
        server.query(statement)
    return iql


# ---- the tests ----


def test_cli_builds_the_target_and_reports_what_it_leaves(rmv, tmp_path):
    out = tmp_path / "k"
    run = rmv("build", "--target", "kapacitor", "examples/carla/abs.rmv", "-o", str(out))
    assert run.code == 0, run.err
    assert "wrote the kapacitor target" in run.out
    names = sorted(
        str(p.relative_to(out)) for p in out.rglob("*")
        if p.is_file() and not str(p.relative_to(out)).startswith("collector/")
    )  # fmt: skip
    assert names == [
        "README.md", "dashboards/chronograf.json", "dashboards/grafana.json", "deploy.json",
        "handlers/publish_alert.py", "influxdb.iql",
        "tickscripts/FastTraffic.tick", "tickscripts/LossOfAcceleration.tick",
        "tickscripts/MaxVelocity.tick",
    ]  # fmt: skip
    assert (out / "collector" / "carla_abs_collector" / "collector_node.py").is_file()
    readme = (out / "README.md").read_text()
    for line in ("property ABSCheck:", "transducer Braking:", "event HardBrake:"):
        assert line in run.err and line in readme
    no_database = tmp_path / "plain.rmv"
    no_database.write_text('system plain\ntopic t: std_msgs/msg/Float64 = "/t"\n')
    run = rmv("build", "--target", "kapacitor", str(no_database), "-o", str(tmp_path / "p"))
    assert run.code == 2 and "needs a `database` block" in run.err
    run = rmv("build", "--target", "kapacitor", "examples/carla/abs.rmv")
    assert run.code == 2 and "needs -o OUT" in run.err


@pytest.mark.parametrize("path", SPECS, ids=[p.stem for p in SPECS])
def test_every_continuous_query_is_created_and_explained(server, path, tmp_path):
    spec = _spec(path)
    iql = _fresh_schema(server, spec, tmp_path)
    database = spec.database
    assert database is not None
    shown = server.query("SHOW CONTINUOUS QUERIES")[0]["series"]
    created = {row[0] for s in shown if s["name"] == database.name for row in s["values"]}
    bodies = continuous_queries(iql)
    assert created == set(bodies) and bodies
    for body in bodies.values():
        server.query("EXPLAIN " + without_into(in_range(body, 0, 3600 * NS)), database.name)


def _worked_spec(declarations: str, index: int, tmp_path: Path) -> ir.Spec:
    header = (
        f'system Doc\ndatabase {{\n    name = "worked_{index}"\n}}\n'
        'topic t: std_msgs/msg/Float64 = "/t"\nvar x = t.data\n'
    )
    return _spec_text(header + declarations + "\n", tmp_path, f"worked_{index}.rmv")


def computed_by_both(
    server: Influxd, spec: ir.Spec, iql: str, rows: list[tuple[Fraction, float]], end: int
) -> tuple[list, list]:
    """Event E's points in InfluxDB, after its continuous query's runs over `rows` of
    topic /t written as the collector writes them, and the runtime's over the same
    messages."""
    for statement in statements(iql):
        server.query(statement)
    writer = lineproto.PointWriter(spec)
    runtime = Runtime(spec)
    lines = []
    for time, value in rows:
        point = writer.point(int(time * NS), "/t", {"data": value})
        assert point is not None
        lines.append(point[1])
        runtime.message(int(time * NS), "/t", {"data": value})
    runtime.end(end)
    server.write(spec.database.name, lines)  # type: ignore[union-attr]
    run_queries(server, spec, iql, 0, end - 1)
    ours = [(int(Fraction(r["time"]) * NS), r["value"]) for r in runtime.records()
            if r.get("name") == "E"]  # fmt: skip
    return stored(server, spec, "E", end), ours


def test_every_function_computes_in_influxdb_what_the_runtime_computes(server, tmp_path):
    """docs/runtime.md's worked example of every function: the event's points in
    InfluxDB, after its continuous query's runs, equal the runtime's."""
    end = 5 * NS
    compared = 0
    for index, (declarations, expected) in enumerate(WORKED):
        spec = _worked_spec(declarations, index, tmp_path)
        texts, report = kapacitor.files(spec, tmp_path / str(index))
        if next(e for e in spec.events if e.name == "E").window is None:
            # a raw event is no continuous query: the report says so
            assert any(line.startswith("event E: no `group by time") for line in report)
            continue
        theirs, ours = computed_by_both(server, spec, texts["influxdb.iql"], WORKED_INPUT, end)
        if expected.strip().startswith("any "):  # `sample` picks at random: each of
            # its points is a row of its window, at the row's own time, N at most
            rows = {(int(t * NS), v) for t, v in WORKED_INPUT}
            per_window = int(expected.split()[1])
            assert theirs and all((t, float(v)) in rows for t, v in theirs), declarations
            windows = [t // NS for t, _ in theirs]
            assert max(windows.count(w) for w in windows) <= per_window, declarations
            continue
        assert len(theirs) == len(ours), (declarations, theirs, ours)
        ulps = 1 if TRANSCENDENTAL.search(declarations) else 0
        for (time, value), (our_time, our_value) in zip(theirs, ours, strict=True):
            assert time == our_time and _same(value, our_value, ulps), (declarations, theirs, ours)
        compared += 1
    assert compared >= 44


OVERFLOWING = [(1, 1e308), (1.5, 1e308), (2, 5.0), (2.5, 6.0), (3, -1e308), (3.5, 1e308),
               (4, 1e200), (4.5, -1e200)]  # fmt: skip


@pytest.mark.parametrize("index, function", list(enumerate(["sum", "stddev", "mean", "spread"])))
def test_a_window_too_great_for_a_double_is_no_point_in_either(server, tmp_path, index, function):
    """Windows whose value overflows to an infinity (a sum past 1.8e308, a square
    of 1e200): InfluxDB writes no such point and still writes the run's others,
    and so does the runtime (whose `stddev` once stopped on Python's OverflowError;
    the C target's differential test found it)."""
    spec = _worked_spec(f"event E = {function}(x) group by time(1s)", 100 + index, tmp_path)
    texts, _ = kapacitor.files(spec, tmp_path / "out")
    rows = [(Fraction(t), v) for t, v in OVERFLOWING]
    theirs, ours = computed_by_both(server, spec, texts["influxdb.iql"], rows, 5 * NS)
    assert len(ours) < 4 and theirs == ours


@pytest.mark.parametrize("index, function", list(enumerate(["mean", "stddev", "sum", "spread"])))
def test_sums_round_in_the_order_influxdb_adds(server, tmp_path, index, function):
    """Thirty windows of 2 to 9 random doubles: every window's value is InfluxDB's
    to the last bit. `mean` is the sum over the count (a running mean, which the
    runtime once took, differs in about half of them); `stddev` subtracts a running
    mean (the sum over the count differs in some)."""
    rng = random.Random(3)
    rows = [
        (Fraction(second) + Fraction(k, 100), rng.uniform(-10, 10))
        for second in range(1, 31)
        for k in range(rng.randint(2, 9))
    ]
    spec = _worked_spec(f"event E = {function}(x) group by time(1s)", 110 + index, tmp_path)
    texts, _ = kapacitor.files(spec, tmp_path / "out")
    theirs, ours = computed_by_both(server, spec, texts["influxdb.iql"], rows, 32 * NS)
    assert len(ours) == 30 and theirs == ours


def test_braking_events_in_influxdb_equal_the_replay(server, tmp_path):
    """The braking recording, written point by point as the collector writes it;
    abs.rmv's continuous queries run as InfluxDB schedules them; every event point
    equals the replay's. (The recording is from the past: its retention policies
    keep data for ever here, or InfluxDB would drop it on arrival.)"""
    spec = _spec(CARLA / "abs.rmv")
    assert spec.database is not None
    forever = tuple(dataclasses.replace(r, duration=None) for r in spec.database.retentions)
    spec = dataclasses.replace(
        spec, database=dataclasses.replace(spec.database, retentions=forever)
    )
    iql = _fresh_schema(server, spec, tmp_path)
    database = spec.database
    assert database is not None
    writer = lineproto.PointWriter(spec)
    reader = open_reader([BRAKING], spec)
    try:
        lines, times = [], []
        for connection, timestamp, raw in reader.messages(
            connections=plan(spec, reader).connections
        ):
            message = reader.deserialize(raw, connection.msgtype)
            point = writer.point(timestamp, connection.topic, message)
            if point is not None:
                times.append(point[0])
                lines.append(point[1])
        end = reader.end_time - 1
    finally:
        reader.close()
    assert len(lines) == 900 and not writer.dropped
    for start in range(0, len(lines), 5000):
        server.write(database.name, lines[start : start + 5000], database.default_retention)
    runs = run_queries(server, spec, iql, min(times), max(times))
    assert runs > 0
    records = list(replay(spec, [BRAKING], record=("event", "state")))
    states = [lineproto.state_point(spec, r["transducer"], r["state"],
                                    int(Fraction(r["time"]) * NS))
              for r in records if r["kind"] == "state"]  # fmt: skip
    assert states  # as the collector writes them, for the dashboards
    server.write(database.name, states, database.default_retention)
    value_events = [e.name for e in spec.events if e.kind == "value"]
    for name in value_events:
        ours = [(int(Fraction(r["time"]) * NS), r["value"]) for r in records
                if r["kind"] == "event" and r["name"] == name]  # fmt: skip
        theirs = stored(server, spec, name, end)
        assert ours, name
        assert len(theirs) == len(ours), (name, len(theirs), len(ours))
        for (time, value), (our_time, our_value) in zip(theirs, ours, strict=True):
            assert time == our_time, (name, time, our_time)
            assert _same(value, our_value) or math.isclose(value, our_value, rel_tol=1e-12), (
                name, time, value, our_value)  # fmt: skip
    _every_dashboard_query_runs(server, spec, tmp_path, min(times), end)


def _every_dashboard_query_runs(
    server: Influxd, spec: ir.Spec, tmp_path: Path, first: int, last: int
) -> None:
    """Every panel of both dashboards, its placeholders given the recording's time
    range, runs on influxd; each shows data, but the alerts (Kapacitor writes them;
    it is not here), whose query must still run."""
    texts = _build(spec, tmp_path / "dashboards")
    grafana = json.loads(texts["dashboards/grafana.json"])
    chronograf = json.loads(texts["dashboards/chronograf.json"])
    queries = [(p["title"], p["targets"][0]["query"]
                .replace("$timeFilter", f"time >= {first} AND time <= {last}")
                .replace("$__interval", "1s")) for p in grafana["panels"]]  # fmt: skip
    cells = chronograf["dashboard"]["cells"]
    queries += [(c["name"], c["queries"][0]["query"]
                 .replace(":dashboardTime:", str(first - 1))
                 .replace(":upperDashboardTime:", str(last + 1))
                 .replace(":interval:", "1s")) for c in cells]  # fmt: skip
    assert len(queries) == 16
    for title, query in queries:
        assert "$" not in query and ":" not in query.replace("http:", ""), query
        rows = server.points(query, spec.database.name)  # type: ignore[union-attr]
        assert (not rows) if title == "alerts" else rows, (title, query)


HOSTILE = ["it's", 'say "hi"', "back\\slash", "ends\\", "a\nb", "'''", "$(rm -rf /)", "; DROP",
           "{{ .ID }}", "\\'", "tab\there", "é✓"]  # fmt: skip


@pytest.mark.parametrize("text", HOSTILE)
def test_influxql_and_line_protocol_keep_hostile_text_as_data(server, text):
    """A hostile text as a database name, a string field (line protocol), a field
    key where line protocol can spell it, and in InfluxQL as an identifier and a
    string literal: each reads back exactly."""
    db_name = f"h_{HOSTILE.index(text)} {text}".replace("\\", "/")  # no `\` in a database name
    valid = "/" not in db_name and all(c.isprintable() for c in db_name)
    db = influxql.identifier(db_name if valid else f"h_{HOSTILE.index(text)}")
    server.query(f"CREATE DATABASE {db}")
    name = _unquote(db)
    if "\\" in text or "\n" in text:
        with pytest.raises(ValueError, match="cannot be a line protocol name"):
            lineproto.key_text(text)
        key = "f"
    else:
        key = text
    line = f"m,topic=/t {lineproto.key_text(key)}={lineproto.field_value(text)} 1"
    server.write(name, [line])
    field = influxql.identifier(key)
    literal = influxql.string(text)
    rows = server.points(f'SELECT {field} FROM "m" WHERE {field} = {literal}', name)
    assert rows == [[1, text]]
    databases = [row[0] for row in server.query("SHOW DATABASES")[0]["series"][0]["values"]]
    assert name in databases


@pytest.mark.parametrize("text", HOSTILE)
def test_tickscript_strings_read_back_as_written(text):
    try:
        literal = tick.string(text)
    except tick.TickError:
        assert text.endswith("\\") and ("'''" in text or text.endswith("'"))
        return
    script = f"stream\n    |from()\n        .measurement({literal})\n"
    assert tickscript.strings(tickscript.check(script)) == [text]
    templated = tick.string(tick.go_template_text(text))
    script = f"stream\n    |from()\n    |alert()\n        .message({templated})\n"
    (value,) = tickscript.strings(tickscript.check(script))
    assert "{{" not in value.replace('{{ "{{" }}', "").replace('{{ "" }}', "")


def test_hostile_spec_gives_valid_tickscript_and_influxql(server, tmp_path):
    spec = _spec(FIXTURES / "kapacitor" / "hostile.rmv")
    texts = _build(spec, tmp_path)
    statements_ = tickscript.check(texts["tickscripts/A.tick"])
    values = tickscript.strings(statements_)
    assert "/bin/echo" in values and "'; rm -rf /" in values and "$(id)" in values
    assert "http://127.0.0.1:1/a'b\"c" in values
    dbrp = next(s for s in statements_ if s[0] == "dbrp")
    assert dbrp[1] == spec.database.name  # type: ignore[union-attr]
    for statement in statements(texts["influxdb.iql"]):
        server.query(statement)
    databases = server.query("SHOW DATABASES")[0]["series"][0]["values"]
    assert [spec.database.name] in databases  # type: ignore[union-attr]


def test_every_tickscript_of_the_examples_parses(tmp_path):
    for path in SPECS:
        texts = _build(_spec(path), tmp_path / path.stem)
        scripts = {k: v for k, v in texts.items() if k.startswith("tickscripts/")}
        for name, text in scripts.items():
            statements_ = tickscript.check(text)
            assert statements_[0][0] == "dbrp", name
    bad = "stream\n    |from()\n        .measurment('m')\n"
    with pytest.raises(tickscript.TickError, match="no property `measurment`"):
        tickscript.check(bad)
    with pytest.raises(tickscript.TickError, match="unterminated string"):
        tickscript.check("stream\n    |from()\n        .measurement('a\\')\n")
    with pytest.raises(tickscript.TickError, match="fields are"):
        tickscript.check("stream\n    |from()\n    |alert()\n        .warn(lambda: x > 1)\n")


def test_durations_are_one_integer_and_one_unit():
    assert influxql.duration(Fraction(90)) == "90s"
    assert influxql.duration(Fraction(3, 2) * 60) == "90s"
    assert influxql.duration(Fraction(1, 10)) == "100ms"
    assert influxql.duration(Fraction(86400 * 30)) == "30d"
    assert influxql.duration(None) == "INF"
    assert tick.duration(Fraction(90)) == "90s"
    assert tick.duration(Fraction(1, 10**6)) == "1u"
    with pytest.raises(tick.TickError):
        tick.duration(Fraction(1, 10**9))


# ---- rmv deploy ----


@pytest.fixture
def kapacitor_api() -> Iterator[KapacitorServer]:
    api = KapacitorServer()
    yield api
    api.stop()


def _deploy(rmv, out: Path, server: Influxd, api: KapacitorServer) -> Any:
    return rmv("deploy", "--target", "kapacitor", str(out), "--influx", server.url,
               "--kapacitor", api.url)  # fmt: skip


def test_deploy_applies_once_then_changes_only_what_differs(rmv, server, kapacitor_api, tmp_path):
    """Kapacitor is not installable here: its task API is played by
    tests/kapacitor/server.py, which holds each request to Kapacitor's rules."""
    out = tmp_path / "k"
    assert rmv("build", "--target", "kapacitor", "examples/carla/abs.rmv", "-o", str(out)).code == 0
    server.query('DROP DATABASE "rmvcps_db"')
    first = _deploy(rmv, out, server, kapacitor_api)
    assert first.code == 0, first.err
    assert "created database rmvcps_db" in first.out
    assert first.out.count("created continuous query") == 4
    assert first.out.count("defined and enabled task") == 3
    tasks = kapacitor_api.state.tasks
    assert sorted(tasks) == ["carla_abs.FastTraffic", "carla_abs.LossOfAcceleration",
                             "carla_abs.MaxVelocity"]  # fmt: skip
    assert all(t["status"] == "enabled" for t in tasks.values())
    assert all(t["dbrps"] == [{"db": "rmvcps_db", "rp": "raw"}] for t in tasks.values())

    seen = len(kapacitor_api.state.requests)
    again = _deploy(rmv, out, server, kapacitor_api)
    assert again.code == 0 and "rmv deploy: 0 changes" in again.out, again.out
    assert {m for m, _, _ in kapacitor_api.state.requests[seen:]} == {"GET"}

    # A changed build: a window, a retention, an alert's message; one alert and
    # one continuous query gone.
    iql = (out / "influxdb.iql").read_text()
    iql = iql.replace("GROUP BY time(1s)\n  fill(previous)", "GROUP BY time(1s)\n  fill(linear)")
    iql = iql.replace('ON "rmvcps_db" DURATION 1d', 'ON "rmvcps_db" DURATION 2d')
    gone = re.search(
        r'\nCREATE CONTINUOUS QUERY "carla_abs.downsample.velocity_1m".*?END;\n', iql, re.S
    )
    assert gone is not None
    (out / "influxdb.iql").write_text(iql.replace(gone.group(0), "\n"))
    tick = out / "tickscripts" / "MaxVelocity.tick"
    tick.write_text(tick.read_text().replace("maximum velocity exceeded", "too fast"))
    manifest = json.loads((out / "deploy.json").read_text())
    manifest["tasks"] = [t for t in manifest["tasks"] if t["id"] != "carla_abs.FastTraffic"]
    (out / "deploy.json").write_text(json.dumps(manifest))
    changed = _deploy(rmv, out, server, kapacitor_api)
    assert changed.code == 0, changed.err
    lines = [line for line in changed.out.splitlines() if "changes," not in line]
    assert sorted(lines) == sorted([
        "rmv deploy: altered retention policy raw on rmvcps_db",
        "rmv deploy: replaced continuous query carla_abs.ObjectsNearby",
        "rmv deploy: dropped continuous query carla_abs.downsample.velocity_1m",
        "rmv deploy: replaced task carla_abs.MaxVelocity",
        "rmv deploy: deleted task carla_abs.FastTraffic",
    ])  # fmt: skip
    assert "too fast" in tasks["carla_abs.MaxVelocity"]["script"]
    assert tasks["carla_abs.MaxVelocity"]["status"] == "enabled"
    shown = server.query("SHOW CONTINUOUS QUERIES")[0]["series"]
    queries = {r[0]: r[1] for s in shown if s["name"] == "rmvcps_db" for r in s["values"]}
    assert "fill(linear)" in queries["carla_abs.ObjectsNearby"] and len(queries) == 3
    assert _deploy(rmv, out, server, kapacitor_api).out.startswith("rmv deploy: 0 changes")


def test_deploy_names_what_failed_and_what_was_applied(rmv, server, kapacitor_api, tmp_path,
                                                       monkeypatch):  # fmt: skip
    out = tmp_path / "k"
    assert rmv("build", "--target", "kapacitor", "examples/carla/abs.rmv", "-o", str(out)).code == 0
    server.query('DROP DATABASE "rmvcps_db"')
    iql = (out / "influxdb.iql").read_text()
    # InfluxDB's second error layer: HTTP 200 with results[].error
    bad = 'CREATE RETENTION POLICY "x" ON "no_such_db" DURATION 1d REPLICATION 1;\n'
    (out / "influxdb.iql").write_text(
        iql.replace("CREATE CONTINUOUS QUERY", bad + "CREATE CONTINUOUS QUERY", 1)
    )
    failed = _deploy(rmv, out, server, kapacitor_api)
    assert failed.code == 1
    assert 'CREATE RETENTION POLICY "x" ON "no_such_db"' in failed.err
    assert "database not found" in failed.err
    assert (
        "applied before it: created database rmvcps_db; created retention policy raw" in failed.err
    )
    # the first layer: HTTP 400 with `error` (a statement InfluxDB cannot parse)
    (out / "influxdb.iql").write_text(
        iql.replace("CREATE CONTINUOUS QUERY", "CREATE NONSENSE;\nCREATE CONTINUOUS QUERY", 1)
    )
    failed = _deploy(rmv, out, server, kapacitor_api)
    assert failed.code == 1 and "HTTP 400" in failed.err and "CREATE NONSENSE" in failed.err
    # a script Kapacitor refuses names the task
    (out / "influxdb.iql").write_text(iql)
    tick = out / "tickscripts" / "FastTraffic.tick"
    tick.write_text(tick.read_text().replace(".warn(", ".wran("))
    failed = _deploy(rmv, out, server, kapacitor_api)
    assert failed.code == 1 and "task carla_abs.FastTraffic" in failed.err
    assert "no property `wran`" in failed.err
    # unreachable
    failed = rmv("deploy", "--target", "kapacitor", str(out), "--influx", "http://127.0.0.1:9")
    assert failed.code == 1 and "cannot connect" in failed.err
    assert rmv("deploy", "--target", "kapacitor", str(tmp_path)).code == 2
    # credentials: from the environment variables the spec names
    monkeypatch.setenv("RMV_INFLUX_USER", "robot")
    monkeypatch.setenv("RMV_INFLUX_PASSWORD", "secret")
    monkeypatch.setenv("KAPACITOR_USERNAME", "operator")
    tick.write_text(tick.read_text().replace(".wran(", ".warn("))
    assert _deploy(rmv, out, server, kapacitor_api).code == 0
    expected = "Basic " + base64.b64encode(b"operator:").decode()
    assert set(kapacitor_api.state.authorizations[-3:]) == {expected}


def test_generated_python_is_lint_clean(tmp_path):
    """The collector package and the publish handler, for the examples and the
    hostile spec: ruff check and ruff format as the project runs them."""
    for path in [*SPECS, FIXTURES / "kapacitor" / "hostile.rmv"]:
        out = tmp_path / path.stem
        kapacitor.write(_spec(path), out)
        for command in (["check"], ["format", "--check"]):
            lint = subprocess.run(
                [sys.executable, "-m", "ruff", *command, "--config",
                 str(ROOT / "pyproject.toml"), str(out)],
                capture_output=True, text=True,
            )  # fmt: skip
            assert lint.returncode == 0, (path.name, lint.stdout + lint.stderr)
    collector = tmp_path / "abs" / "collector" / "carla_abs_collector"
    assert (collector / "rmv_host" / "ros2.py").exists()


GOLDEN = ROOT / "tests" / "golden" / "kapacitor"


@pytest.mark.parametrize("path", SPECS, ids=[p.stem for p in SPECS])
def test_build_matches_golden(path):
    """The queries, scripts and dashboards of each example, exactly. Regenerate with
    `UPDATE_GOLDEN=1 pytest tests/test_kapacitor.py -k golden` after a deliberate
    change, and read `git diff tests/golden/kapacitor` as code. (The collector
    package and the handler carry the build's folder, so they are left out.)"""
    texts, report = kapacitor.files(_spec(path), Path("/build"))
    kept = {k: v for k, v in texts.items() if k.startswith(("influxdb", "tickscripts/",
                                                            "dashboards/"))}  # fmt: skip
    kept["report.txt"] = "\n".join(report) + "\n"
    folder = GOLDEN / path.stem
    if os.environ.get("UPDATE_GOLDEN"):
        for relative, text in kept.items():
            (folder / relative).parent.mkdir(parents=True, exist_ok=True)
            (folder / relative).write_text(text, encoding="utf-8")
    found = {str(p.relative_to(folder)): p.read_text(encoding="utf-8")
             for p in folder.rglob("*") if p.is_file()}  # fmt: skip
    assert found == kept
