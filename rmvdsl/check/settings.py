"""What each block's `key = value` settings may be, and the check of one block."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

from rmvdsl.diagnostics import Diagnostic, Label, did_you_mean, error
from rmvdsl.grammar import ast

Validator = Callable[[ast.Value], str | None]


def _names(*allowed: str) -> Validator:
    def check(value: ast.Value) -> str | None:
        if isinstance(value, ast.NameValue) and value.ident.name in allowed:
            return None
        return "expected one of " + ", ".join(f"`{a}`" for a in allowed)

    return check


def _string(value: ast.Value) -> str | None:
    return None if isinstance(value, ast.StringLit) else "expected a string in double quotes"


def _secret(value: ast.Value) -> str | None:
    return None if isinstance(value, ast.EnvRef) else 'expected env("VARIABLE")'


def _string_or_env(value: ast.Value) -> str | None:
    if isinstance(value, ast.StringLit | ast.EnvRef):
        return None
    return 'expected a string or env("VARIABLE")'


def _bool(value: ast.Value) -> str | None:
    return None if isinstance(value, ast.BoolLit) else "expected `true` or `false`"


def _integer(low: int, high: int | None = None) -> Validator:
    def check(value: ast.Value) -> str | None:
        if isinstance(value, ast.NumberLit) and value.value.denominator == 1:
            number = int(value.value)
            if number >= low and (high is None or number <= high):
                return None
        upper = f"..{high}" if high is not None else " or more"
        return f"expected a whole number {low}{upper}"

    return check


def _time(value: ast.Value) -> str | None:
    if isinstance(value, ast.TimeLit):
        return None if value.time.value > 0 else "expected a positive time"
    return "expected a time with a unit, such as `10s` or `100ms`"


def _time_or_infinite(value: ast.Value) -> str | None:
    if isinstance(value, ast.NameValue) and value.ident.name == "inf":
        return None
    return _time(value)


def _rate(value: ast.Value) -> str | None:
    if isinstance(value, ast.RateLit):
        return None if value.hertz > 0 else "expected a positive rate"
    return "expected a rate in Hz, such as `10Hz`"


def _name(value: ast.Value) -> str | None:
    return None if isinstance(value, ast.NameValue) else "expected a name"


def _name_list(value: ast.Value) -> str | None:
    if isinstance(value, ast.ListValue) and all(isinstance(v, ast.NameValue) for v in value.items):
        return None
    return "expected a list of names, such as `[Velocity, BrakePedal]`"


def _string_list(value: ast.Value) -> str | None:
    if isinstance(value, ast.ListValue) and all(isinstance(v, ast.StringLit) for v in value.items):
        return None
    return 'expected a list of strings, such as `["/rosout"]`'


@dataclass(frozen=True)
class Schema:
    block: str
    settings: dict[str, Validator]
    required: tuple[str, ...] = ()
    secret: frozenset[str] = frozenset()


INFLUX_PRECISIONS = ("ns", "u", "us", "ms", "s", "m", "h")

DATABASE = Schema(
    "database",
    {
        "url": _string,
        "host": _string,
        "port": _integer(1, 65535),
        "name": _string,
        "precision": _names(*INFLUX_PRECISIONS),
        "username": _string_or_env,
        "password": _secret,
        "token": _secret,
        "ssl": _bool,
        "timeout": _time,
        "batch_size": _integer(1),
        "flush_interval": _time,
    },
    required=("name",),
    secret=frozenset({"password", "token"}),
)
RETENTION = Schema(
    "retention policy",
    {
        "duration": _time_or_infinite,
        "replication": _integer(1),
        "shard_duration": _time,
        "default": _bool,
    },
    required=("duration",),
)
AGGREGATES = ("count", "distinct", "integral", "mean", "median", "mode", "spread", "stddev", "sum")
SELECTORS = ("bottom", "first", "last", "max", "min", "percentile", "sample", "top")
DOWNSAMPLE = Schema(
    "downsample",
    {
        "from": _name,
        "into": _name,
        "every": _time,
        "for": _time,
        "aggregate": _names(*AGGREGATES, *SELECTORS),
        "measurements": _name_list,
    },
    required=("into", "every"),
)
QOS = Schema(
    "qos",
    {
        "depth": _integer(1),
        "history": _names("keep_last", "keep_all"),
        "reliability": _names("reliable", "best_effort"),
        "durability": _names("volatile", "transient_local"),
        "deadline": _time,
        "lifespan": _time,
        "liveliness": _names("automatic", "manual_by_topic"),
        "liveliness_lease": _time,
    },
)
ALERT = Schema(
    "alert",
    {
        "id": _string,
        "details": _string,
        "state_changes_only": _bool,
        "no_recoveries": _bool,
    },
)
PROPERTY = Schema(
    "property",
    {
        "rate": _rate,
        "trigger": _name,
        "window": _time,
        "lateness": _time,
    },
)
INTRUSION = Schema(
    "intrusion",
    {
        "poll": _time,
        "default": _names("allow", "deny"),
        "ignore_nodes": _string_list,
    },
)


def check_settings(
    schema: Schema,
    settings: Iterable[ast.Setting],
    owner: ast.Ident | None,
    owner_span: ast.Node,
) -> list[Diagnostic]:
    diagnostics: list[Diagnostic] = []
    seen: dict[str, ast.Setting] = {}
    for setting in settings:
        key = setting.key.name
        if key in seen:
            diagnostics.append(_duplicate(setting, seen[key]))
            continue
        seen[key] = setting
        validator = schema.settings.get(key)
        if validator is None:
            diagnostics.append(_unknown(schema, setting))
            continue
        if key in schema.secret and isinstance(setting.value, ast.StringLit):
            diagnostics.append(_clear_secret(setting))
            continue
        problem = validator(setting.value)
        if problem:
            diagnostics.append(
                error(
                    "RMV208",
                    f"invalid value for `{key}` in {schema.block}",
                    setting.value.span,
                    label=problem,
                    help=_unit_fix(setting.value, problem),
                )
            )
    for key in schema.required:
        if key not in seen:
            where = f" `{owner.name}`" if owner else ""
            diagnostics.append(
                error(
                    "RMV209",
                    f"{schema.block}{where} has no `{key}`",
                    owner.span if owner else owner_span.span,
                    label=f"`{key} = ...` is required",
                    help=f"add `{key} = {_EXAMPLES.get(key, '...')}` to the block",
                )
            )
    return diagnostics


_EXAMPLES = {"name": '"rmv"', "duration": "7d", "into": "archive", "every": "1m"}


def _duplicate(setting: ast.Setting, first: ast.Setting) -> Diagnostic:
    return error(
        "RMV214",
        f"`{setting.key.name}` is set more than once",
        setting.key.span,
        label="set again here",
        secondary=[Label(first.key.span, "first set here")],
        help="keep only one",
    )


def _unknown(schema: Schema, setting: ast.Setting) -> Diagnostic:
    known = sorted(schema.settings)
    return error(
        "RMV207",
        f"unknown setting `{setting.key.name}` in {schema.block}",
        setting.key.span,
        label="not a setting of this block",
        help=did_you_mean(setting.key.name, known)
        or "allowed: " + ", ".join(f"`{k}`" for k in known),
    )


def _clear_secret(setting: ast.Setting) -> Diagnostic:
    variable = f"RMV_INFLUX_{setting.key.name.upper()}"
    return error(
        "RMV211",
        f"`{setting.key.name}` is written in clear",
        setting.value.span,
        label="credentials must not be stored in the spec",
        help=f'write `{setting.key.name} = env("{variable}")` and export {variable}',
    )


def _unit_fix(value: ast.Value, problem: str) -> str | None:
    """A bare number where a time or a rate is needed: the unit it lacks."""
    if not isinstance(value, ast.NumberLit):
        return None
    if "rate" in problem:
        return f"a rate needs its unit: `{value.text}Hz`"
    if "time" in problem:
        return f"a time needs its unit: `{value.text}s` (or `ms`, `m`, ...)"
    return None
