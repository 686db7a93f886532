"""The InfluxQL and TICKscript dialects (rmvdsl/dialects/): what the kapacitor
target prints parses back to the tree it printed; the queries a real InfluxDB's
SHOW prints parse too; every quoting rule reads back as the text it quoted; and a
malformed text is an error naming where, never a crash."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest
from conftest import EXAMPLES, FIXTURES
from hypothesis import example, given
from hypothesis import strategies as st
from influx.server import Influxd

from rmvdsl.check import check
from rmvdsl.dialects import influxql
from rmvdsl.dialects import tickscript as tick
from rmvdsl.importers.tickscript import convert_tickscript
from rmvdsl.ir import lower
from rmvdsl.targets import kapacitor
from rmvdsl.targets.kapacitor.deploy import DeployError, Report, deploy_influx

SPECS = [
    EXAMPLES / "carla" / "abs.rmv",
    EXAMPLES / "gazebo" / "prius_platoon.rmv",
    FIXTURES / "kapacitor" / "hostile.rmv",
]


def _build(path: Path, out: Path) -> tuple[Any, dict[str, str]]:
    spec = lower(check(str(path)))
    texts, _ = kapacitor.files(spec, out)
    return kapacitor.plan(spec, out.resolve() / "handlers"), texts


@pytest.mark.parametrize("path", SPECS, ids=lambda p: p.stem)
def test_the_printed_influxql_parses_back_to_its_tree(path, tmp_path):
    build, texts = _build(path, tmp_path)
    assert influxql.parse(texts["influxdb.iql"]) == kapacitor.statements(build)


@pytest.mark.parametrize("path", SPECS, ids=lambda p: p.stem)
def test_the_printed_tickscripts_parse_back_and_print_the_same(path, tmp_path):
    build, texts = _build(path, tmp_path)
    assert build.alerts
    for alert in build.alerts:
        parsed = tick.parse(texts[alert.file])
        assert [type(s).__name__ for s in parsed] == ["Dbrp", "Pipeline", "Pipeline"]
        assert tuple(tick.statement(s) for s in parsed) == alert.script


def _values(expr: Any) -> Any:
    """A tree with each number literal as its value (SHOW prints `3.6` as `3.600`)."""
    if isinstance(expr, influxql.Literal):
        try:
            return influxql.Literal(repr(float(expr.text)))
        except ValueError:
            return expr
    if dataclasses.is_dataclass(expr) and not isinstance(expr, type):
        changes = {f.name: _values(getattr(expr, f.name)) for f in dataclasses.fields(expr)}
        return dataclasses.replace(expr, **changes)
    if isinstance(expr, tuple):
        return tuple(_values(item) for item in expr)
    return expr


def test_the_queries_influxdb_shows_parse_to_what_was_created(tmp_path):
    """Real influxd reformats a continuous query (bare names, `3.600`, minimal
    parentheses); `rmv deploy` compares what it shows, so it must read it."""
    (tmp_path / "influxd").mkdir()
    server = Influxd(tmp_path / "influxd")
    try:
        for index, path in enumerate(SPECS):
            build, _ = _build(path, tmp_path / str(index))
            for statement in kapacitor.statements(build):
                server.query(influxql.statement(statement))
            shown = {
                name: text
                for series in server.query("SHOW CONTINUOUS QUERIES")[0]["series"]
                if series["name"] == build.database.name
                for name, text in series.get("values", [])
            }
            assert set(shown) == {q.name for q in build.queries}
            for query in build.queries:
                parsed = influxql.parse_query(shown[query.name])
                assert _values(parsed) == _values(query), shown[query.name]
            server.query(influxql.statement(influxql.DropDatabase(build.database.name)))
    finally:
        server.stop()


TEXT = st.text(st.characters(exclude_categories=["Cs"]), max_size=40)


@given(TEXT)
def test_influxql_quoting_reads_back(text):
    (ident,) = influxql.tokens(influxql.identifier(text))
    (literal,) = influxql.tokens(influxql.string(text))
    assert (ident.kind, influxql.value(ident)) == ("ident", text)
    assert (literal.kind, influxql.value(literal)) == ("string", text)


@given(TEXT)
@example('\\"')  # Kapacitor's lexer: a backslash escapes the quote only
@example("\\'")
@example("a\\\\b")
def test_tickscript_quoting_reads_back_or_is_refused(text):
    for quote, kind in ((tick.string, "string"), (tick.reference, "reference")):
        try:
            written = quote(text)
        except tick.TickError:
            assert text.endswith("\\") or "\n" in text
            continue
        (token,) = tick.tokens(written)
        assert (token.kind, tick.value(token)) == (kind, text)


def test_the_influxql_parser_reads_precedence_and_shown_forms():
    query = influxql.parse_query(
        'CREATE CONTINUOUS QUERY "q" ON db BEGIN SELECT a + b * -2 AS x INTO db.rp.m '
        "FROM db.rp.m WHERE a > 1 AND b < 2 OR c = 'it\\'s' GROUP BY time(1s, 5ms), * "
        "fill(-1) ORDER BY time DESC LIMIT 3 END"
    )
    a, b, c = influxql.Name("a"), influxql.Name("b"), influxql.Name("c")
    product = influxql.Binary("*", b, influxql.Unary("-", influxql.Literal("2")))
    assert query.select.columns == ((influxql.Binary("+", a, product), "x"),)
    assert query.select.where == influxql.Binary(
        "OR",
        influxql.Binary("AND", influxql.Binary(">", a, influxql.Literal("1")),
                        influxql.Binary("<", b, influxql.Literal("2"))),
        influxql.Binary("=", c, influxql.Text("it's")),
    )  # fmt: skip
    select = query.select
    assert (select.interval, select.offset, select.every_tag) == ("1s", "5ms", True)
    assert (select.fill, select.descending, select.limit) == ("-1", True, 3)


@pytest.mark.parametrize(
    "text, message",
    [
        ("CREATE DATABASE", "expected a name, found the end"),
        ('CREATE DATABASE "a', "unclosed"),
        ("CREATE DATABASE a b", "unexpected `b` at offset 18"),
        ('CREATE CONTINUOUS QUERY "q" ON d BEGIN SELECT a INTO d.r.m', "expected `AS`"),
        ("CREATE RETENTION POLICY r ON d DURATION 1x REPLICATION 1", "expected a duration"),
        ("SELECT # FROM m", "unexpected '#' at offset 7"),
    ],
)
def test_malformed_influxql_is_an_error_naming_where(text, message):
    with pytest.raises(influxql.InfluxQLError, match=message):
        influxql.parse(text)


def test_statements_the_dialect_does_not_model_are_kept_as_written():
    assert influxql.parse("SHOW DATABASES; -- a comment\n DROP MEASUREMENT m") == [
        influxql.Other("SHOW DATABASES"),
        influxql.Other("DROP MEASUREMENT m"),
    ]


def test_deploy_refuses_a_malformed_file_before_applying_anything():
    with pytest.raises(DeployError, match=r"influxdb\.iql: expected a name"):
        deploy_influx(None, "CREATE DATABASE;", "x.", Report())


@pytest.mark.parametrize(
    "script, message",
    [
        ("stream |from() .measurement('a", "unclosed ' at offset 28"),
        ("stream |from( .x()", "unexpected `.` at offset 14"),
        ("stream | 5()", "expected a name after `|`"),
        ("var = stream", "expected `=`"),
        ("stream |alert() .warn(lambda: ) ", r"unexpected `\)`"),
        ("stream # x", "unexpected '#' at offset 7"),
    ],
)
def test_malformed_tickscript_is_an_error_and_an_import_note(script, message):
    with pytest.raises(tick.TickError, match=message):
        tick.parse(script)
    alert, notes = convert_tickscript(script, "A")
    assert alert is None and notes and "not TICKscript" in notes[0]


def test_lambdas_import_with_the_parentheses_rmv_needs():
    script = (
        "stream |from() .measurement('m') |alert()"
        ' .warn(lambda: ("value" > 1 OR "b" == 2) AND !("c" < 3 - (4 - 5)))'
        " .crit(lambda: \"value\" * (2 + 3) >= 'x''')"
    )
    alert, notes = convert_tickscript(script.replace("'x'''", "'x'"), "A")
    assert notes == []
    assert alert == (
        "alert A {\n"
        "    warn when (m > 1 or b = 2) and not c < 3 - (4 - 5)\n"
        '    crit when m * (2 + 3) >= "x"\n'
        "}"
    )


HAND_EDITED = (
    'CREATE DATABASE "lab";\n'
    'CREATE CONTINUOUS QUERY "lab.hourly" ON "lab" BEGIN SELECT mean("v") AS "v" '
    'INTO "lab"."autogen"."hourly" FROM "lab"."autogen"."m" GROUP BY time(1h), "topic" END;\n'
)


def test_a_query_the_dialect_does_not_model_is_kept_as_written():
    """A hand-edited influxdb.iql (GROUP BY a tag): the head is parsed, the SELECT
    kept as written, and it prints back."""
    _, query = influxql.parse(HAND_EDITED)
    assert isinstance(query, influxql.CreateContinuousQuery)
    assert (query.name, query.database) == ("lab.hourly", "lab")
    assert query.select == (
        'SELECT mean("v") AS "v" INTO "lab"."autogen"."hourly" FROM "lab"."autogen"."m" '
        'GROUP BY time(1h), "topic"'
    )
    assert influxql.parse(influxql.statement(query)) == [query]
    with pytest.raises(influxql.InfluxQLError, match="expected `AS`"):
        influxql.parse('CREATE CONTINUOUS QUERY "q" ON "d" BEGIN SELECT x')  # and no END


def test_deploy_applies_a_hand_edited_query_once(tmp_path):
    """rmv deploy compares what InfluxDB shows of it, as for its own queries."""
    from rmvdsl.targets.kapacitor.deploy import Influx

    (tmp_path / "influxd").mkdir()
    server = Influxd(tmp_path / "influxd")
    try:
        influx = Influx(server.url, None, None)
        first, second = Report(), Report()
        deploy_influx(influx, HAND_EDITED, "lab.", first)
        deploy_influx(influx, HAND_EDITED, "lab.", second)
    finally:
        server.stop()
    assert first.applied == ["created database lab", "created continuous query lab.hourly"]
    assert second.applied == []
    assert second.unchanged == ["database lab", "continuous query lab.hourly"]
