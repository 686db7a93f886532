"""The check of one block's `key = value` settings against the registry
(rmvdsl.lang.builtins.BLOCKS): the validator of each kind of value."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from fractions import Fraction

from rmvdsl.grammar import ast
from rmvdsl.lang import builtins
from rmvdsl.lang.diagnostics import Diagnostic, Label, did_you_mean, error

Validator = Callable[[ast.Value], str | None]


def _names(*allowed: str) -> Validator:
    def check(value: ast.Value) -> str | None:
        if isinstance(value, ast.NameValue) and value.ident.name in allowed:
            return None
        return "expected one of " + ", ".join(f"`{a}`" for a in allowed)

    return check


def _string(value: ast.Value) -> str | None:
    return None if isinstance(value, ast.StringLit) else "expected a string in double quotes"


def _influx_name(value: ast.Value) -> str | None:
    """A database name InfluxDB 1.x accepts (meta.ValidName): printable, not empty,
    `.` or `..`, with no `/` or `\\` (it names a folder on the server)."""
    if not isinstance(value, ast.StringLit):
        return "expected a string in double quotes"
    name = value.value
    if name in ("", ".", "..") or any(c in "/\\" or not c.isprintable() for c in name):
        return "InfluxDB refuses this name: printable characters, no `/` or `\\`"
    return None


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


_NANOSECOND = Fraction(1, 10**9)  # times are whole nanoseconds, as InfluxDB's


def _time(value: ast.Value) -> str | None:
    if isinstance(value, ast.TimeLit):
        if value.time.value <= 0:
            return "expected a positive time"
        seconds = value.time.seconds()
        return None if seconds is None or seconds >= _NANOSECOND else "expected at least 1ns"
    return "expected a time with a unit, such as `10s` or `100ms`"


def _time_or_infinite(value: ast.Value) -> str | None:
    if isinstance(value, ast.NameValue) and value.ident.name == "inf":
        return None
    return _time(value)


def _rate(value: ast.Value) -> str | None:
    if isinstance(value, ast.RateLit):
        if value.hertz <= 0:
            return "expected a positive rate"
        return None if value.hertz <= 1 / _NANOSECOND else "expected at most 1e9Hz (1ns apart)"
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


_VALIDATORS: dict[str, Validator] = {
    "string": _string,
    "influx_name": _influx_name,
    "secret": _secret,
    "string_or_env": _string_or_env,
    "bool": _bool,
    "time": _time,
    "time_or_inf": _time_or_infinite,
    "rate": _rate,
    "name": _name,
    "name_list": _name_list,
    "string_list": _string_list,
}


def validator(spec: builtins.SettingSpec) -> Validator:
    """The check of one setting's value, from its kind in the registry."""
    if spec.kind == "names":
        return _names(*spec.choices)
    if spec.kind == "int":
        return _integer(spec.low if spec.low is not None else 0, spec.high)
    return _VALIDATORS[spec.kind]


def check_settings(
    block_name: str,
    settings: Iterable[ast.Setting],
    owner: ast.Ident | None,
    owner_span: ast.Node,
) -> list[Diagnostic]:
    schema = builtins.block(block_name)
    diagnostics: list[Diagnostic] = []
    seen: dict[str, ast.Setting] = {}
    for setting in settings:
        key = setting.key.name
        if key in seen:
            diagnostics.append(_duplicate(setting, seen[key]))
            continue
        seen[key] = setting
        spec = schema.settings.get(key)
        if spec is None:
            diagnostics.append(_unknown(schema, setting))
            continue
        if key in schema.secret and isinstance(setting.value, ast.StringLit):
            diagnostics.append(_clear_secret(setting))
            continue
        problem = validator(spec)(setting.value)
        if problem:
            diagnostics.append(
                error(
                    "RMV208",
                    f"invalid value for `{key}` in {schema.name}",
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
                    f"{schema.name}{where} has no `{key}`",
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


def _unknown(schema: builtins.Block, setting: ast.Setting) -> Diagnostic:
    known = sorted(schema.settings)
    return error(
        "RMV207",
        f"unknown setting `{setting.key.name}` in {schema.name}",
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
