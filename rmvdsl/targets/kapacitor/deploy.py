"""`rmv deploy --target kapacitor OUT`: apply a build to InfluxDB and Kapacitor over
their HTTP APIs (docs/kapacitor.md, "Deploy").

Idempotent: what the servers already hold as the build says is left alone; what
differs is replaced, and only that; continuous queries and tasks of the same system
that the build no longer has are removed. Credentials come from the environment
only (the variables the spec's `database` block names, or INFLUX_USERNAME/
INFLUX_PASSWORD; KAPACITOR_USERNAME/KAPACITOR_PASSWORD). Any refusal stops the
deployment with the statement or task that failed and the list of what was applied
before it.
"""

from __future__ import annotations

import base64
import dataclasses
import json
import os
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rmvdsl.dialects import influxql

MANIFEST = "deploy.json"
SCRATCH = "_rmv_deploy_scratch"  # where a continuous query shows its canonical form
TIMEOUT = 30.0


class DeployError(Exception):
    """A server refused something, or could not be reached."""


# ---- HTTP ----


@dataclass
class Http:
    base: str
    username: str | None = None
    password: str | None = None

    def request(self, method: str, path: str, body: bytes | None = None,
                content_type: str = "application/json") -> tuple[int, Any]:  # fmt: skip
        request = urllib.request.Request(self.base.rstrip("/") + path, data=body, method=method)
        if body is not None:
            request.add_header("Content-Type", content_type)
        if self.username is not None:
            token = base64.b64encode(f"{self.username}:{self.password or ''}".encode()).decode()
            request.add_header("Authorization", f"Basic {token}")
        try:
            with urllib.request.urlopen(request, timeout=TIMEOUT) as answer:
                return answer.status, _json(answer.read())
        except urllib.error.HTTPError as error:
            return error.code, _json(error.read())
        except (urllib.error.URLError, OSError) as error:
            reason = getattr(error, "reason", error)
            raise DeployError(f"{self.base}: cannot connect: {reason}") from None


def _json(data: bytes) -> Any:
    try:
        return json.loads(data) if data else None
    except json.JSONDecodeError:
        return {"error": data.decode(errors="replace")[:500]}


class Influx:
    """InfluxDB 1.x's `/query`, with both of its error layers."""

    def __init__(self, url: str, username: str | None, password: str | None) -> None:
        self.http = Http(url, username, password)

    def query(self, statement: str, db: str | None = None) -> list[dict[str, Any]]:
        fields = {"q": statement, **({"db": db} if db else {})}
        status, body = self.http.request(
            "POST", "/query", urllib.parse.urlencode(fields).encode(),
            "application/x-www-form-urlencoded",
        )  # fmt: skip
        if status >= 400 or body is None:
            error = body.get("error") if isinstance(body, dict) else None
            raise DeployError(f"InfluxDB answered HTTP {status}: {error or body}")
        for result in body.get("results", []):
            if result.get("error"):
                raise DeployError(f"InfluxDB refused it: {result['error']}")
        return list(body.get("results", []))

    def rows(self, statement: str, db: str | None = None) -> list[dict[str, Any]]:
        """Every row of every series, as mappings (with the series' name as `series`)."""
        out = []
        for result in self.query(statement, db):
            for series in result.get("series", []):
                for values in series.get("values", []):
                    out.append({"series": series.get("name"),
                                **dict(zip(series["columns"], values, strict=True))})  # fmt: skip
        return out


# ---- the deployment ----


@dataclass
class Report:
    applied: list[str] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)

    def did(self, what: str) -> None:
        self.applied.append(what)

    def failed(self, what: str, why: str) -> DeployError:
        done = "; ".join(self.applied) if self.applied else "nothing"
        return DeployError(f"{what}: {why}\napplied before it: {done}")


def _run(report: Report, what: str, action: Callable[..., Any], *args: Any) -> Any:
    """`action(*args)`; a refusal names `what` and what was applied before it."""
    try:
        return action(*args)
    except DeployError as error:
        raise report.failed(what, str(error)) from None


def _statements(iql: str) -> list[influxql.Statement]:
    try:
        return influxql.parse(iql)
    except influxql.InfluxQLError as why:
        raise DeployError(f"influxdb.iql: {why}") from None


def deploy_influx(influx: Influx, iql: str, prefix: str, report: Report) -> None:
    """Apply the statements of `influxdb.iql`, changing only what differs (a file
    that does not parse is refused before anything is applied)."""
    statements = _statements(iql)
    shown = _run(report, "SHOW DATABASES", influx.rows, "SHOW DATABASES")
    databases = {r["name"] for r in shown}
    wanted_queries: dict[str, set[str]] = {}
    for statement in statements:
        text = influxql.statement(statement)
        if isinstance(statement, influxql.CreateDatabase):
            if statement.database in databases:
                report.unchanged.append(f"database {statement.database}")
            else:
                _run(report, text, influx.query, text)
                report.did(f"created database {statement.database}")
                databases.add(statement.database)
        elif isinstance(statement, influxql.CreateRetentionPolicy):
            _retention(influx, statement, report)
        elif isinstance(statement, influxql.CreateContinuousQuery):
            wanted_queries.setdefault(statement.database, set()).add(statement.name)
            _continuous_query(influx, statement, report)
        else:
            _run(report, text, influx.query, text)
            report.did(text.splitlines()[0])
    for db, names in wanted_queries.items():
        _drop_obsolete_queries(influx, db, names, prefix, report)


def _retention(influx: Influx, policy: influxql.CreateRetentionPolicy, report: Report) -> None:
    db, name, statement = policy.database, policy.name, influxql.statement(policy)
    show = f"SHOW RETENTION POLICIES ON {influxql.identifier(db)}"
    existing = {r["name"]: r for r in _run(report, statement, influx.rows, show)}
    current = existing.get(name)
    if current is None:
        _run(report, statement, influx.query, statement)
        report.did(f"created retention policy {name} on {db}")
        return
    same = (
        influxql.duration_ns(str(current["duration"])) == influxql.duration_ns(policy.duration)
        and int(current["replicaN"]) == policy.replication
        and bool(current["default"]) == policy.default
        and (
            policy.shard_duration is None
            or influxql.duration_ns(str(current["shardGroupDuration"]))
            == influxql.duration_ns(policy.shard_duration)
        )
    )
    if same:
        report.unchanged.append(f"retention policy {name} on {db}")
        return
    alter = statement.replace("CREATE RETENTION POLICY", "ALTER RETENTION POLICY", 1)
    _run(report, alter, influx.query, alter)
    report.did(f"altered retention policy {name} on {db}")


def _shown_queries(influx: Influx, db: str, report: Report) -> dict[str, str]:
    rows = _run(report, "SHOW CONTINUOUS QUERIES", influx.rows, "SHOW CONTINUOUS QUERIES")
    return {r["name"]: r["query"] for r in rows if r["series"] == db}


def _meaning(shown: str) -> tuple[str | None, str | None, influxql.Select | str] | None:
    """What a query as SHOW prints it does, without its name and database: its
    resample clause and its SELECT (None: a query this module cannot read, which
    is then replaced)."""
    try:
        query = influxql.parse_query(shown)
    except influxql.InfluxQLError:
        return None
    return query.resample_every, query.resample_for, query.select


def _canonical(
    influx: Influx, query: influxql.CreateContinuousQuery, report: Report
) -> tuple[str | None, str | None, influxql.Select | str] | None:
    """What the query does as InfluxDB prints it (SHOW reformats what CREATE was
    given: durations, parentheses), found by creating it once in a scratch database."""
    statement = influxql.statement(query)
    scratch = influxql.statement(dataclasses.replace(query, name=SCRATCH, database=SCRATCH))
    create = influxql.statement(influxql.CreateDatabase(SCRATCH))
    _run(report, create, influx.query, create)
    try:
        _run(report, statement, influx.query, scratch)
        return _meaning(_shown_queries(influx, SCRATCH, report)[SCRATCH])
    finally:
        influx.query(influxql.statement(influxql.DropDatabase(SCRATCH)))


def _continuous_query(
    influx: Influx, query: influxql.CreateContinuousQuery, report: Report
) -> None:
    statement, name = influxql.statement(query), query.name
    existing = _shown_queries(influx, query.database, report).get(name)
    if existing is not None:
        wanted = _canonical(influx, query, report)
        if wanted is not None and _meaning(existing) == wanted:
            report.unchanged.append(f"continuous query {name}")
            return
        drop = influxql.statement(influxql.DropContinuousQuery(name, query.database))
        _run(report, drop, influx.query, drop)
        _run(report, statement, influx.query, statement)
        report.did(f"replaced continuous query {name}")
        return
    _run(report, statement, influx.query, statement)
    report.did(f"created continuous query {name}")


def _drop_obsolete_queries(
    influx: Influx, db: str, wanted: set[str], prefix: str, report: Report
) -> None:
    for name in sorted(_shown_queries(influx, db, report)):
        if name.startswith(prefix) and name not in wanted:
            drop = influxql.statement(influxql.DropContinuousQuery(name, db))
            _run(report, drop, influx.query, drop)
            report.did(f"dropped continuous query {name}")


# ---- Kapacitor ----


def _kapacitor_error(status: int, body: Any) -> str:
    error = body.get("error") if isinstance(body, dict) else None
    return f"Kapacitor answered HTTP {status}: {error or body}"


def deploy_kapacitor(http: Http, tasks: list[dict[str, Any]], prefix: str,
                     report: Report) -> None:  # fmt: skip
    """Define and enable each task; a changed one is patched, then disabled and
    enabled again (Kapacitor applies a patch to a running task only then). The
    scripts name their database and retention policy (`dbrp`): Kapacitor refuses
    a request that also gives `dbrps` (services/task_store/service.go)."""
    base = "/kapacitor/v1/tasks"
    for task in tasks:
        what = f"task {task['id']}"
        status, current = http.request(
            "GET", f"{base}/{urllib.parse.quote(task['id'], safe='')}?script-format=raw"
        )
        path = f"{base}/{urllib.parse.quote(task['id'], safe='')}"
        if status == 404:
            _kapacitor(http, "POST", base, {**task, "status": "enabled"}, what, report)
            report.did(f"defined and enabled {what}")
            continue
        if status >= 400:
            raise report.failed(what, _kapacitor_error(status, current))
        same = all(current.get(k) == task[k] for k in ("type", "script"))
        if same and current.get("status") == "enabled":
            report.unchanged.append(what)
            continue
        if not same:
            changes = {k: task[k] for k in ("type", "script")}
            _kapacitor(http, "PATCH", path, {**changes, "status": "disabled"}, what, report)
        _kapacitor(http, "PATCH", path, {"status": "enabled"}, what, report)
        report.did(f"{'replaced' if not same else 'enabled'} {what}")
    wanted = {t["id"] for t in tasks}
    query = urllib.parse.urlencode({"pattern": f"{prefix}*", "fields": "id", "limit": "1000"})
    status, body = http.request("GET", f"{base}?{query}")
    if status >= 400:
        raise report.failed("listing the tasks", _kapacitor_error(status, body))
    for task in (body or {}).get("tasks", []):
        if task["id"] not in wanted:
            path = f"{base}/{urllib.parse.quote(task['id'], safe='')}"
            _kapacitor(http, "DELETE", path, None, f"task {task['id']}", report)
            report.did(f"deleted task {task['id']}")


def _kapacitor(http: Http, method: str, path: str, body: dict[str, Any] | None, what: str,
               report: Report) -> None:  # fmt: skip
    data = None if body is None else json.dumps(body).encode()
    status, answer = http.request(method, path, data)
    if status >= 400:
        raise report.failed(what, _kapacitor_error(status, answer))


# ---- the command ----


def _credential(name: str | None, fallback: str) -> str | None:
    return os.environ.get(name or fallback) or None


def deploy(out: Path, influx_url: str | None, kapacitor_url: str | None) -> Report:
    """Deploy the build in `out`: InfluxDB first, then the Kapacitor tasks."""
    try:
        manifest = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
        iql = (out / "influxdb.iql").read_text(encoding="utf-8")
        scripts = {t["id"]: (out / t["file"]).read_text(encoding="utf-8")
                   for t in manifest["tasks"]}  # fmt: skip
    except (OSError, ValueError, KeyError) as error:
        raise DeployError(
            f"{out}: not a build of `rmv build --target kapacitor` ({error})"
        ) from None
    report = Report()
    influx = Influx(
        influx_url or manifest["influx_url"],
        _credential(manifest.get("username_env"), "INFLUX_USERNAME"),
        _credential(manifest.get("password_env"), "INFLUX_PASSWORD"),
    )
    deploy_influx(influx, iql, manifest["prefix"], report)
    http = Http(
        kapacitor_url or manifest["kapacitor_url"],
        _credential(None, "KAPACITOR_USERNAME"),
        _credential(None, "KAPACITOR_PASSWORD"),
    )
    tasks = [
        {"id": t["id"], "type": t["type"], "script": scripts[t["id"]]} for t in manifest["tasks"]
    ]
    if tasks or kapacitor_url is not None:
        deploy_kapacitor(http, tasks, manifest["prefix"], report)
    else:
        report.unchanged.append("Kapacitor (no alert tasks to define)")
    return report
