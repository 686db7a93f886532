"""InfluxQL's tree as the kapacitor target writes it, the one quoting rule for
each kind of literal, and the printer."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from rmvdsl.dialects.common import Binary, Call, Literal, Text, Unary, printed


class InfluxQLError(ValueError):
    """A text that is not InfluxQL, or a value InfluxQL cannot hold."""


# ---- quoting: the one rule for each kind of literal ----


def identifier(name: str) -> str:
    """Any name as an identifier: double quotes, with `\\`, `"` and a newline
    escaped (influxql's scanner reads quoted identifiers as strings)."""
    text = name.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{text}"'


def string(value: str) -> str:
    """Any text as a string literal: single quotes, `\\`, `'` and a newline escaped."""
    text = value.replace("\\", "\\\\").replace("'", "\\'").replace("\n", "\\n")
    return f"'{text}'"


def unquote(token: str) -> str:
    """What a quoted identifier or string literal stands for (a bare word: itself)."""
    if len(token) < 2 or token[0] not in "\"'" or token[-1] != token[0]:
        return token
    out, index, body = [], 0, token[1:-1]
    while index < len(body):
        char = body[index]
        if char == "\\" and index + 1 < len(body):
            index += 1
            char = {"n": "\n"}.get(body[index], body[index])
        out.append(char)
        index += 1
    return "".join(out)


# Units from the largest: a duration is written as a whole number of one unit.
UNITS: tuple[tuple[str, int | Fraction], ...] = (
    ("w", 604800), ("d", 86400), ("h", 3600), ("m", 60), ("s", 1),
    ("ms", Fraction(1, 10**3)), ("u", Fraction(1, 10**6)), ("ns", Fraction(1, 10**9)),
)  # fmt: skip


def whole(seconds: Fraction, units: tuple[tuple[str, int | Fraction], ...]) -> str | None:
    """The duration as a whole number of the largest unit that divides it."""
    for unit, size in units:
        count = Fraction(seconds) / size
        if count.denominator == 1 and count >= 1:
            return f"{count.numerator}{unit}"
    return None


def duration(seconds: Fraction | None) -> str:
    """A duration literal (`90s`, `100ms`); `INF` for forever (None)."""
    if seconds is None:
        return "INF"
    if seconds == 0:
        return "0s"
    text = whole(Fraction(seconds), UNITS)
    if text is None:
        raise InfluxQLError(f"{seconds} s is not a whole number of nanoseconds")
    return text


NS_PER_UNIT = {"ns": 1, "u": 10**3, "µ": 10**3, "us": 10**3, "µs": 10**3, "ms": 10**6, "s": 10**9,
       "m": 60 * 10**9, "h": 3600 * 10**9, "d": 86400 * 10**9, "w": 604800 * 10**9}  # fmt: skip


def duration_ns(text: str) -> int:
    """A duration as InfluxQL writes it (`30d`, `INF`) or as SHOW prints it, Go's
    way (`720h0m0s`, `0s` for forever), in nanoseconds (0: forever)."""
    if text.upper() == "INF":
        return 0
    total, index = 0, 0
    while index < len(text):
        start = index
        while index < len(text) and (text[index].isdigit() or text[index] == "."):
            index += 1
        unit_start = index
        while index < len(text) and (text[index].isalpha() or text[index] == "µ"):
            index += 1
        number, unit = text[start:unit_start], text[unit_start:index]
        if not number or unit not in NS_PER_UNIT:
            raise InfluxQLError(f"`{text}` is not a duration")
        total += int(float(number) * NS_PER_UNIT[unit])
    return total


# ---- the tree ----


@dataclass(frozen=True)
class Name:
    """A field or tag: printed quoted."""

    name: str


Expr = Name | Literal | Text | Binary | Unary | Call


@dataclass(frozen=True)
class Measurement:
    database: str
    retention: str
    name: str


@dataclass(frozen=True)
class Select:
    columns: tuple[tuple[Expr, str], ...]  # each expression and its `AS` name
    into: Measurement
    source: Measurement
    where: Expr | None
    interval: str  # GROUP BY time(interval[, offset])
    offset: str | None
    every_tag: bool  # GROUP BY ..., *
    fill: str | None
    descending: bool
    limit: int | None


@dataclass(frozen=True)
class CreateDatabase:
    database: str


@dataclass(frozen=True)
class CreateRetentionPolicy:
    name: str
    database: str
    duration: str
    replication: int
    shard_duration: str | None
    default: bool


@dataclass(frozen=True)
class CreateContinuousQuery:
    name: str
    database: str
    resample_every: str | None
    resample_for: str | None
    select: Select | str  # a SELECT this module does not model: as written


@dataclass(frozen=True)
class DropContinuousQuery:
    name: str
    database: str


@dataclass(frozen=True)
class DropDatabase:
    database: str


@dataclass(frozen=True)
class Other:
    """A statement this module does not model, kept as written."""

    text: str


Statement = (
    CreateDatabase
    | CreateRetentionPolicy
    | CreateContinuousQuery
    | DropContinuousQuery
    | DropDatabase
    | Other
)


# ---- the printer ----


def expression(expr: Expr) -> str:
    """An expression, operands parenthesised so the tree is the one printed
    whatever InfluxQL's precedence."""
    return printed(expr, lambda node: identifier(node.name) if isinstance(node, Name) else None,
                   string)  # fmt: skip


def measurement(target: Measurement) -> str:
    return ".".join(identifier(n) for n in (target.database, target.retention, target.name))


def _select_lines(select: Select) -> list[str]:
    columns = ", ".join(f"{expression(e)} AS {identifier(n)}" for e, n in select.columns)
    window = select.interval + (f", {select.offset}" if select.offset else "")
    group = f"time({window})" + (", *" if select.every_tag else "")
    lines = [f"SELECT {columns}", f"INTO {measurement(select.into)}",
             f"FROM {measurement(select.source)}"]  # fmt: skip
    if select.where is not None:
        lines.append(f"WHERE {expression(select.where)}")
    lines.append(f"GROUP BY {group}")
    if select.fill is not None:
        lines.append(f"fill({select.fill})")
    if select.descending:
        lines.append("ORDER BY time DESC")
    if select.limit is not None:
        lines.append(f"LIMIT {select.limit}")
    return lines


def statement(stmt: Statement) -> str:
    """A statement as `influxdb.iql` holds it (without its `;`); a continuous
    query over several lines, its SELECT indented."""
    match stmt:
        case CreateDatabase():
            return f"CREATE DATABASE {identifier(stmt.database)}"
        case CreateRetentionPolicy():
            shard = "" if stmt.shard_duration is None else f" SHARD DURATION {stmt.shard_duration}"
            return (
                f"CREATE RETENTION POLICY {identifier(stmt.name)} ON {identifier(stmt.database)} "
                f"DURATION {stmt.duration} REPLICATION {stmt.replication}{shard}"
                + (" DEFAULT" if stmt.default else "")
            )
        case CreateContinuousQuery():
            on = f"{identifier(stmt.name)} ON {identifier(stmt.database)}"
            head = [f"CREATE CONTINUOUS QUERY {on}"]
            if stmt.resample_every or stmt.resample_for:
                every = f" EVERY {stmt.resample_every}" if stmt.resample_every else ""
                for_ = f" FOR {stmt.resample_for}" if stmt.resample_for else ""
                head.append(f"RESAMPLE{every}{for_}")
            lines = [stmt.select] if isinstance(stmt.select, str) else _select_lines(stmt.select)
            body = ["  " + line for line in lines]
            return "\n".join([*head, "BEGIN", *body, "END"])
        case DropContinuousQuery():
            return f"DROP CONTINUOUS QUERY {identifier(stmt.name)} ON {identifier(stmt.database)}"
        case DropDatabase():
            return f"DROP DATABASE {identifier(stmt.database)}"
        case Other():
            return stmt.text
