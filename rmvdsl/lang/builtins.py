"""Every built-in name of the language, in one place: InfluxQL functions, array
aggregates, actions and the settings of every block, each with its arity, argument
kinds, result rule, default and the text an editor shows on hover.

The checker validates against these tables, `rmvdsl.ir` fills defaults from them,
the runtime implements exactly these functions, docs/language.md's tables are
generated from them (a test keeps the two equal), and a test fails when code asks
for a name that is not here. Standard library only: generated nodes embed it.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Any


class UnknownBuiltin(KeyError):
    """Code asked for a built-in the registry lacks: a bug, never a user error."""


# ---- InfluxQL functions (events and alerts) ----


@dataclass(frozen=True)
class Function:
    name: str
    group: str  # aggregation | selector | transformation
    least: int  # fewest arguments
    most: int  # most arguments
    wants: str  # what the first argument must be: any | numeric
    result: str  # same | int | float | rate-1 | rate+1 | duration
    second: str | None  # the second argument: time (a unit) | count | percent | number
    doc: str
    shape: str = ""  # how the docs write a call, where `x` and `N` would mislead

    @property
    def arity(self) -> str:
        return str(self.least) if self.least == self.most else f"{self.least} to {self.most}"

    def with_shape(self, shape: str) -> Function:
        return dataclasses.replace(self, shape=shape)


def _f(
    name: str, group: str, arity: tuple[int, int], wants: str, result: str,
    second: str | None, doc: str,
) -> Function:  # fmt: skip
    return Function(name, group, arity[0], arity[1], wants, result, second, doc)


_AGG, _SEL, _TRANS = "aggregation", "selector", "transformation"
_MATH = {
    "sqrt": "the square root", "exp": "e to the power of the value", "ln": "the natural logarithm",
    "log2": "the base-2 logarithm", "log10": "the base-10 logarithm", "sin": "the sine (radians)",
    "cos": "the cosine (radians)", "tan": "the tangent (radians)", "asin": "the arcsine",
    "acos": "the arccosine", "atan": "the arctangent",
}  # fmt: skip

FUNCTIONS: dict[str, Function] = {
    f.name: f
    for f in (
        _f("count", _AGG, (1, 1), "any", "int", None, "the number of non-null values"),
        _f("distinct", _AGG, (1, 1), "any", "same", None, "the unique values of the window"),
        _f("integral", _AGG, (1, 2), "numeric", "rate+1", "time",
           "the area under the curve (trapezoids), in the given time unit (default 1s)"),
        _f("mean", _AGG, (1, 1), "numeric", "float", None, "the arithmetic mean of the window"),
        _f("median", _AGG, (1, 1), "numeric", "float", None, "the middle value of the window"),
        _f("mode", _AGG, (1, 1), "any", "same", None,
           "the most frequent value (the smallest of equally frequent ones)"),
        _f("spread", _AGG, (1, 1), "numeric", "same", None, "the maximum minus the minimum"),
        _f("stddev", _AGG, (1, 1), "numeric", "float", None, "the sample standard deviation"),
        _f("sum", _AGG, (1, 1), "numeric", "same", None, "the sum of the window's values"),
        _f("bottom", _SEL, (2, 2), "numeric", "same", "count", "the N smallest values"),
        _f("first", _SEL, (1, 1), "any", "same", None, "the value with the oldest time stamp"),
        _f("last", _SEL, (1, 1), "any", "same", None, "the value with the newest time stamp"),
        _f("max", _SEL, (1, 1), "numeric", "same", None, "the greatest value"),
        _f("min", _SEL, (1, 1), "numeric", "same", None, "the smallest value"),
        _f("percentile", _SEL, (2, 2), "numeric", "same", "percent",
           "the value at the N-th percentile (N from 0 to 100), nearest rank"),
        _f("sample", _SEL, (2, 2), "any", "same", "count", "N values picked at random"),
        _f("top", _SEL, (2, 2), "numeric", "same", "count", "the N greatest values"),
        _f("abs", _TRANS, (1, 1), "numeric", "same", None, "the absolute value"),
        _f("ceil", _TRANS, (1, 1), "numeric", "same", None, "rounded up to an integer"),
        _f("floor", _TRANS, (1, 1), "numeric", "same", None, "rounded down to an integer"),
        _f("round", _TRANS, (1, 1), "numeric", "same", None,
           "rounded to the nearest integer (halves away from zero)"),
        _f("pow", _TRANS, (2, 2), "numeric", "float", "number", "the value to the power of N"),
        _f("atan2", _TRANS, (2, 2), "numeric", "float", None,
           "the angle of the point (x, y), in radians").with_shape("atan2(y, x)"),
        _f("log", _TRANS, (2, 2), "numeric", "float", "number",
           "the logarithm to base b").with_shape("log(x, b)"),
        *(_f(name, _TRANS, (1, 1), "numeric", "float", None, doc) for name, doc in _MATH.items()),
        _f("cumulative_sum", _TRANS, (1, 1), "numeric", "same", None,
           "the running total of the values so far"),
        _f("derivative", _TRANS, (1, 2), "numeric", "rate-1", "time",
           "the rate of change between consecutive values, per time unit (default 1s)"),
        _f("non_negative_derivative", _TRANS, (1, 2), "numeric", "rate-1", "time",
           "`derivative`, without its negative values"),
        _f("difference", _TRANS, (1, 1), "numeric", "same", None,
           "the value minus the one before it"),
        _f("non_negative_difference", _TRANS, (1, 1), "numeric", "same", None,
           "`difference`, without its negative values"),
        _f("moving_average", _TRANS, (2, 2), "numeric", "float", "count",
           "the mean of the last N values"),
        _f("elapsed", _TRANS, (1, 2), "any", "duration", "time",
           "the time between consecutive values, in the given unit (default 1ns)"),
    )
}  # fmt: skip
AGGREGATIONS = tuple(n for n, f in FUNCTIONS.items() if f.group == _AGG)
SELECTORS = tuple(n for n, f in FUNCTIONS.items() if f.group == _SEL)

# Reductions of a `[*]` path to one value in a variable, and `number(...)`.
ARRAY_AGGREGATES: dict[str, str] = {
    "min": "the smallest element",
    "max": "the greatest element",
    "sum": "the sum of the elements",
    "mean": "the mean of the elements (a float)",
    "count": "the number of elements",
    "any": "true when some element is true",
    "all": "true when every element is true (also for none)",
}
NUMBER = "number"  # `number(path)`: one bool as 0 or 1
FILLS = ("none", "null", "previous", "linear")  # or a number
# What ROS itself has every node use (`intrusion { infrastructure = ros }`), by ROS
# version and role: never an intrusion, unless a whitelist names the topic.
INFRASTRUCTURE: dict[int, dict[str, tuple[str, ...]]] = {
    1: {"publisher": ("/rosout",), "subscriber": ("/clock",)},
    2: {"publisher": ("/rosout", "/parameter_events"),
        "subscriber": ("/parameter_events", "/clock")},
}  # fmt: skip


def _infrastructure_text() -> str:
    """INFRASTRUCTURE in words, for the setting's hover and the docs' table."""
    parts = []
    for version, given in INFRASTRUCTURE.items():
        uses = ", ".join(
            f"{_VERBS[role]} {' and '.join(f'`{t}`' for t in topics)}"
            for role, topics in given.items()
        )
        parts.append(f"ROS {version}: {uses}")
    return "; ".join(parts)


_VERBS = {"publisher": "publish", "subscriber": "subscribe to"}


# The rosbags type store of each ROS distribution: the checker's message types and
# the replay's decoder read the same one.
TYPE_STORES = {
    "noetic": "ROS1_NOETIC", "melodic": "ROS1_NOETIC", "kinetic": "ROS1_NOETIC",
    "dashing": "ROS2_DASHING", "eloquent": "ROS2_ELOQUENT", "foxy": "ROS2_FOXY",
    "galactic": "ROS2_GALACTIC", "humble": "ROS2_HUMBLE", "iron": "ROS2_IRON",
    "jazzy": "ROS2_JAZZY", "kilted": "ROS2_KILTED",
}  # fmt: skip
ORDERS = ("asc", "desc")


def _lookup(table: dict[str, Any], what: str, name: str) -> Any:
    try:
        return table[name]
    except KeyError:
        raise UnknownBuiltin(f"{what} {name}") from None


def function(name: str) -> Function:
    found: Function = _lookup(FUNCTIONS, "function", name)
    return found


# ---- actions ----


@dataclass(frozen=True)
class Parameter:
    name: str
    kind: str  # string | topic | url | address | command | strings | time | level
    default: Any = None
    doc: str = ""


@dataclass(frozen=True)
class ActionSpec:
    name: str
    positional: tuple[str, ...]  # in order
    required: int  # how many of the positional ones are required
    parameters: dict[str, Parameter]
    doc: str

    @property
    def keywords(self) -> tuple[str, ...]:
        return tuple(self.parameters)


LOG_LEVELS = ("debug", "info", "warn", "error", "fatal")


def _action(
    name: str, positional: tuple[str, ...], required: int, doc: str, *parameters: Parameter
) -> ActionSpec:
    return ActionSpec(name, positional, required, {p.name: p for p in parameters}, doc)


ACTIONS: dict[str, ActionSpec] = {
    a.name: a
    for a in (
        _action(
            "log", ("message",), 0, "write a line to the monitor's log",
            Parameter("message", "string", None, "the text (default: the owner's message)"),
            Parameter("level", "level", None,
                      "debug, info, warn, error or fatal (default: the alert's level, "
                      "`error` for properties and intrusions)"),
        ),
        _action(
            "publish", ("topic", "message"), 1, "publish a std_msgs/String on a ROS topic",
            Parameter("topic", "topic", None, "the ROS topic"),
            Parameter("message", "string", None, "the text (default: the owner's message)"),
        ),
        _action(
            "post", ("url",), 1, "send an HTTP POST of the event as JSON",
            Parameter("url", "url", None, "where to post"),
            Parameter("timeout", "time", Fraction(10), "how long to wait (default 10s)"),
        ),
        _action(
            "exec", ("command", "args"), 1,
            "run a program, with the event as JSON on its standard input (no shell)",
            Parameter("command", "command", None, "the program"),
            Parameter("args", "strings", (), "its arguments: a string or a list of strings"),
        ),
        _action(
            "tcp", ("address",), 1, "send the event as one JSON line to a TCP address",
            Parameter("address", "address", None, "host:port"),
        ),
    )
}  # fmt: skip


def action(name: str) -> ActionSpec:
    found: ActionSpec = _lookup(ACTIONS, "action", name)
    return found


# ---- settings of blocks ----

# The value a setting takes when the spec leaves it out and the default depends on
# the rest of the spec (the text says what).
DERIVED = "derived"


@dataclass(frozen=True)
class SettingSpec:
    key: str
    kind: str  # string | secret | string_or_env | bool | int | time | time_or_inf | rate
    #            | name | names | name_list | string_list
    default: Any = None  # None: absent means "not set" (the doc says what that means)
    doc: str = ""
    choices: tuple[str, ...] = ()  # for `names`
    low: int | None = None  # for `int`
    high: int | None = None
    shown: str = ""  # the default as the docs write it


@dataclass(frozen=True)
class Block:
    name: str  # as diagnostics say it
    settings: dict[str, SettingSpec]
    required: tuple[str, ...] = ()
    secret: frozenset[str] = frozenset()


def _s(key: str, kind: str, default: Any, doc: str, shown: str = "", **more: Any) -> SettingSpec:
    return SettingSpec(key, kind, default, doc, shown=shown, **more)


def _block(name: str, *settings: SettingSpec, required: tuple[str, ...] = ()) -> Block:
    secret = frozenset(s.key for s in settings if s.kind == "secret")
    return Block(name, {s.key: s for s in settings}, required, secret)


INFLUX_PRECISIONS = ("ns", "u", "us", "ms", "s", "m", "h")
_S = Fraction

BLOCKS: dict[str, Block] = {
    "database": _block(
        "database",
        _s("url", "string", DERIVED, "the server's URL", "`http://HOST:PORT`"),
        _s("host", "string", "127.0.0.1", "the server's host", '`"127.0.0.1"`'),
        _s("port", "int", 8086, "the server's port", "`8086`", low=1, high=65535),
        _s("name", "influx_name", None, "the database name (required)", "required"),
        _s("precision", "names", "ns", "the time stamp precision of writes (the thesis's "
           "`epoch`)", "`ns`", choices=INFLUX_PRECISIONS),
        _s("username", "string_or_env", None, 'a string or `env("...")`', "none"),
        _s("password", "secret", None, '`env("...")` only', "none"),
        _s("token", "secret", None, '`env("...")` only', "none"),
        _s("ssl", "bool", False, "HTTPS instead of HTTP", "`false`"),
        _s("timeout", "time", _S(5), "how long a write may take", "`5s`"),
        _s("batch_size", "int", 5000, "points written per request", "`5000`", low=1),
        _s("flush_interval", "time", _S(1), "the longest a point waits to be written", "`1s`"),
        required=("name",),
    ),
    "retention": _block(
        "retention policy",
        _s("duration", "time_or_inf", None, "how long data is kept (`inf`: forever)", "required"),
        _s("replication", "int", 1, "the replication factor", "`1`", low=1),
        _s("shard_duration", "time", None, "the shard group duration", "InfluxDB's choice"),
        _s("default", "bool", False, "writes without a policy go here", "`false`"),
        required=("duration",),
    ),
    "downsample": _block(
        "downsample",
        _s("from", "name", DERIVED, "the retention policy read", "the default policy"),
        _s("into", "name", None, "the retention policy written", "required"),
        _s("every", "time", None, "how often it runs, and its window", "required"),
        _s("for", "time", DERIVED, "how far back each run reads", "`every`"),
        _s("aggregate", "names", "mean", "the InfluxQL aggregate or selector", "`mean`",
           choices=(*AGGREGATIONS, *SELECTORS)),
        _s("measurements", "name_list", DERIVED, "the variables and events it reads",
           "all of them"),
        required=("into", "every"),
    ),
    "qos": _block(
        "qos",
        _s("depth", "int", 10, "the history depth", "`10`", low=1),
        _s("history", "names", "keep_last", "which messages are kept", "`keep_last`",
           choices=("keep_last", "keep_all")),
        _s("reliability", "names", "reliable", "delivery guarantee", "`reliable`",
           choices=("reliable", "best_effort")),
        _s("durability", "names", "volatile", "whether late joiners get old messages",
           "`volatile`", choices=("volatile", "transient_local")),
        _s("deadline", "time", None, "the longest gap between messages", "none"),
        _s("lifespan", "time", None, "how long a message stays valid", "none"),
        _s("liveliness", "names", "automatic", "how publishers show they are alive",
           "`automatic`", choices=("automatic", "manual_by_topic")),
        _s("liveliness_lease", "time", None, "the liveliness lease duration", "none"),
        _s("time", "names", "receipt", "a message's time: when it arrived (`receipt`) or "
           "its `header.stamp` (`header`)", "`receipt`", choices=("receipt", "header")),
        _s("max_rate", "rate", None, "the most messages a second the topic is declared to "
           "carry: each message past it is counted and reported (it is still read)", "none"),
    ),
    "alert": _block(
        "alert",
        _s("id", "string", DERIVED, "the alert's identifier", "its name"),
        _s("details", "string", "", "a longer text sent with the alert", '`""`'),
        _s("state_changes_only", "bool", False, "act only when the level changes", "`false`"),
        _s("no_recoveries", "bool", False, "do not act when the alert returns to OK",
           "`false`"),
    ),
    "property": _block(
        "property",
        _s("rate", "rate", None, "how often the verdict is sampled and reported",
           "every instant (exact segments)"),
        _s("trigger", "name", "always", "when the monitor runs: `always`, or while a state "
           "or boolean event holds", "`always`"),
        _s("window", "time", DERIVED, "how much history the monitor keeps",
           "the property's horizon"),
        _s("lateness", "time", _S(0), "how late input may arrive and still be ordered in",
           "`0s`"),
    ),
    "intrusion": _block(
        "intrusion",
        _s("poll", "time", _S(1), "how often the ROS graph is read", "`1s`"),
        _s("default", "names", "allow", "topics without a whitelist: `allow` or `deny`",
           "`allow`", choices=("allow", "deny")),
        _s("ignore_nodes", "string_list", (), "node patterns never reported", "`[]`"),
        _s("infrastructure", "names", "ros", "what every node may use: `ros` (ROS's own "
           f"topics: {_infrastructure_text()}), or `none`", "`ros`", choices=("ros", "none")),
    ),
}  # fmt: skip


def block(name: str) -> Block:
    found: Block = _lookup(BLOCKS, "block", name)
    return found


def setting(block_name: str, key: str) -> SettingSpec:
    found: SettingSpec = _lookup(block(block_name).settings, f"setting of {block_name}:", key)
    return found


# ---- the reference tables of docs/language.md ----


def settings_markdown(block_name: str) -> str:
    """The table of a block's settings, as docs/language.md shows it."""
    rows = ["| setting | value | default |", "|---|---|---|"]
    for spec in block(block_name).settings.values():
        value = spec.doc
        if spec.choices:
            value += ": " + ", ".join(f"`{c}`" for c in spec.choices)
        rows.append(f"| `{spec.key}` | {value} | {spec.shown or '`' + str(spec.default) + '`'} |")
    return "\n".join(rows)


def functions_markdown() -> str:
    rows = ["| function | kind | what it gives |", "|---|---|---|"]
    for f in FUNCTIONS.values():
        args = "x" + {None: "", "time": ", unit", "count": ", N", "percent": ", N",
                      "number": ", N"}[f.second]  # fmt: skip
        if f.least == 1 and f.most == 2:
            args = args.replace(", ", "[, ") + "]"
        rows.append(f"| `{f.shape or f'{f.name}({args})'}` | {f.group} | {f.doc} |")
    return "\n".join(rows)


def actions_markdown() -> str:
    rows = ["| action | arguments |", "|---|---|"]
    for a in ACTIONS.values():
        parts = []
        for name, p in a.parameters.items():
            place = "positional or " if name in a.positional else ""
            need = "required" if name in a.positional[: a.required] else "optional"
            parts.append(f"`{name}` ({place}keyword, {need}): {p.doc}")
        rows.append(f"| `{a.name}`: {a.doc} | {'; '.join(parts)} |")
    return "\n".join(rows)


_MARKER = re.compile(r"(<!-- builtins:(\S+) -->\n)(.*?)(<!-- /builtins -->)", re.S)


def reference_table(name: str) -> str:
    """The generated table a `<!-- builtins:NAME -->` marker of the docs holds."""
    if name == "functions":
        return functions_markdown()
    if name == "actions":
        return actions_markdown()
    return settings_markdown(name)


def sync_reference(text: str) -> str:
    """The text with every marked table regenerated from the registry."""
    return _MARKER.sub(lambda m: m.group(1) + reference_table(m.group(2)) + "\n" + m.group(4), text)


if __name__ == "__main__":  # python -m rmvdsl.lang.builtins docs/language.md
    import sys

    for name in sys.argv[1:]:
        with open(name, encoding="utf-8") as handle:
            current = handle.read()
        with open(name, "w", encoding="utf-8") as handle:
            handle.write(sync_reference(current))
