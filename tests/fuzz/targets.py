"""What is fuzzed: every entry point that reads user data, each as one function of
bytes that raises when rmv does something other than answer (a result, or an
error in words with exit status 1 or 2).

The command targets run `rmvdsl.cli.main` in this process, as `rmv` runs it, with
RMV_DEBUG=1 so that a bug escapes as the exception it is instead of rmv's one-line
"internal error"; the data is the file the command reads. The rest call the one
function a command or a node calls: the ROS 1 host's decoder, the importers'
InfluxQL and TICKscript readers. Seeds are the repository's own files."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES, FIXTURES = ROOT / "examples", ROOT / "tests" / "fixtures"
REGRESSIONS = FIXTURES / "fuzz"  # every crash found: <target>/<name>, replayed by test_fuzz

OneInput = Callable[[bytes], None]


class Crash(Exception):
    """rmv did something other than answer: a wrong exit status, a lost server."""


@dataclass(frozen=True)
class Target:
    name: str
    about: str
    seeds: Callable[[Path], list[bytes]]  # given a scratch folder
    prepare: Callable[[Path], OneInput]  # given a scratch folder of its own
    words: tuple[str, ...] = ()  # a dictionary for the mutator: the format's tokens
    # The hang limit of an input, in multiples of the run's `--timeout`.
    patience: float = 1.0


def _files(*patterns: str) -> Callable[[Path], list[bytes]]:
    def seeds(_: Path) -> list[bytes]:
        found = sorted({p for pattern in patterns for p in ROOT.glob(pattern) if p.is_file()})
        return [p.read_bytes() for p in found]

    return seeds


def _quiet_cli(argv: list[str]) -> int:
    """`rmv ARGV` in this process, its output thrown away; exceptions escape. The
    sink is a real file: libFuzzer's timeout report writes to stderr's descriptor."""
    from rmvdsl import cli

    with contextlib.redirect_stdout(_SINK), contextlib.redirect_stderr(_SINK):
        return cli.main(argv)


_SINK = open(os.devnull, "w")  # noqa: SIM115 (for the process's life)


def _command(make_argv: Callable[[Path], list[str]], name: str) -> Callable[[Path], OneInput]:
    """A target running `rmv` on the input written to `folder/name`."""

    def prepare(folder: Path) -> OneInput:
        path = folder / name
        return _running(make_argv(path), path)

    return prepare


def _replay(kind: str) -> Callable[[Path], OneInput]:
    """`rmv replay SPEC RECORDING` on a recording whose storage file is the input
    (a .bag file; the .db3 or .mcap file of a rosbag2 folder, its metadata kept)."""

    def prepare(folder: Path) -> OneInput:
        spec, recording = _recording(folder, kind)
        storage = recording if kind == "bag" else next(recording.glob(f"*.{kind}"))
        return _running(["replay", str(spec), str(recording), "--format", "jsonl"], storage)

    return prepare


# What a fuzzing process runs under (set by tests.fuzz's child, and by
# tests/test_fuzz.py for the test only): a bug raises instead of printing rmv's one
# line, and no answer is kept between inputs.
ENVIRONMENT = {"RMV_DEBUG": "1", "RMV_CACHE_DIR": "", "NO_COLOR": "1"}


def _running(argv: list[str], path: Path) -> OneInput:
    """`rmv ARGV` on each input written to `path`: an exception escapes (RMV_DEBUG),
    an exit status other than 0, 1 and 2 is a crash."""

    def one(data: bytes) -> None:
        path.write_bytes(data)
        code = _quiet_cli(argv)
        if code not in (0, 1, 2):
            raise Crash(f"rmv {' '.join(argv)} exited with {code}")

    return one


def _recording(folder: Path, kind: str) -> tuple[Path, Path]:
    """A spec and a 20-message recording of it (tests/fleet_recordings.py)."""
    import fleet_recordings

    spec = folder / "fleet.rmv"
    spec.write_text(fleet_recordings.SPEC, encoding="utf-8")
    made = folder / "made"
    shutil.rmtree(made, ignore_errors=True)
    made.mkdir()
    recording = fleet_recordings.write(made / "run", kind, fleet_recordings.speeds(3, 20))
    return spec, recording


def _recording_seed(kind: str) -> Callable[[Path], list[bytes]]:
    def seeds(folder: Path) -> list[bytes]:
        _, recording = _recording(folder, kind)
        storage = recording if kind == "bag" else next(recording.glob(f"*.{kind}"))
        return [storage.read_bytes()]

    return seeds


def _trace_seeds(_: Path) -> list[bytes]:
    """Traces in each shape `rmv eval` reads: states, propositions, an end; keys in
    any order, ints and floats, extra fields."""
    return [
        b'{"t": 0, "state": "a"}\n{"t": 1.5, "state": "b"}\n{"t": 3, "end": true}\n',
        b'{"t": 0, "props": ["a"]}\n{"props": ["a", "b"], "t": 2}\n{"t": 2.25, "props": []}\n',
        b'{"state": "b", "t": 0, "note": {"x": [1, 2]}}\n{"end": true, "t": 1e1}\n',
        b"t,a,b\n0,1,0\n1,0,1\n2.5,1,1\n",
    ]


def _ros1_decoder(_: Path) -> OneInput:
    """The ROS 1 host's decoder, as a node gets a message: the connection header's
    definition of carla_msgs/CarlaEgoVehicleStatus, the input as its bytes."""
    from rmvdsl.host.ros1_decoding import DecodeError, Decoder

    header = {"type": "carla_msgs/CarlaEgoVehicleStatus", "md5sum": "*",
              "message_definition": _carla_definition()}  # fmt: skip
    decoder = Decoder()

    def one(data: bytes) -> None:
        with contextlib.suppress(DecodeError):  # the node counts these as damaged
            decoder.decode(header, data)

    return one


def _carla_definition() -> str:
    """The definition text a ROS 1 publisher sends: the type, then each nested type
    after a `MSG:` line."""
    folder = EXAMPLES / "carla" / "msg" / "carla_msgs" / "msg"
    text = (folder / "CarlaEgoVehicleStatus.msg").read_text(encoding="utf-8")
    control = (folder / "CarlaEgoVehicleControl.msg").read_text(encoding="utf-8")
    header = "uint32 seq\ntime stamp\nstring frame_id\n"
    vector = "float64 x\nfloat64 y\nfloat64 z\n"
    parts = [
        text.replace("std_msgs/Header", "Header"),
        "MSG: std_msgs/Header\n" + header,
        "MSG: geometry_msgs/Accel\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
        "MSG: geometry_msgs/Vector3\n" + vector,
        "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
        "MSG: carla_msgs/CarlaEgoVehicleControl\n" + control.replace("std_msgs/Header", "Header"),
    ]
    return ("\n" + "=" * 80 + "\n").join(parts)


def _ros1_seed(_: Path) -> list[bytes]:
    """CarlaEgoVehicleStatus messages as rosbags writes them for ROS 1."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    name = "carla_msgs/msg/CarlaEgoVehicleStatus"
    store.register(get_types_from_msg(_carla_definition(), name))
    return [bytes(store.serialize_ros1(_zero(store, name), name))]


def _zero(store: object, name: str) -> object:
    """A message of `name` with every field zero or empty."""
    fields = store.get_msgdef(name).fields  # type: ignore[attr-defined]
    values = {}
    for field_name, (kind, detail) in fields:
        values[field_name] = _zero_of(store, kind, detail)
    return store.types[name](**values)  # type: ignore[attr-defined]


def _zero_of(store: object, kind: object, detail: object) -> object:
    from rosbags.interfaces import Nodetype

    if kind == Nodetype.BASE:
        base = detail[0]  # type: ignore[index]
        return "" if base == "string" else 0.0 if base.startswith("float") else (
            False if base == "bool" else 0)  # fmt: skip
    if kind == Nodetype.NAME:
        return _zero(store, detail)  # type: ignore[arg-type]
    return []


def _influxql(_: Path) -> OneInput:
    """The InfluxQL reader: `rmv import`'s conversion of an InfluxQL condition (it
    never fails: what it cannot read it keeps for the checker) and the dialect's
    parser of a whole statement, which may refuse with InfluxQLError only."""
    from rmvdsl.dialects import influxql
    from rmvdsl.importers.influxql import influx_expression

    def one(data: bytes) -> None:
        text = data.decode("utf-8", errors="replace")
        influx_expression(text)
        with contextlib.suppress(influxql.InfluxQLError):
            influxql.parse(text)

    return one


def _tickscript(_: Path) -> OneInput:
    from rmvdsl.importers.tickscript import convert_tickscript

    def one(data: bytes) -> None:
        convert_tickscript(data.decode("utf-8", errors="replace"), "A")

    return one


def _influxql_seeds(_: Path) -> list[bytes]:
    """The statements the kapacitor target writes for the examples, and the
    conditions of the thesis's YAML."""
    from rmvdsl.dialects.influxql import split

    seeds = []
    for path in sorted((ROOT / "tests" / "golden").rglob("*.iql")):
        seeds += [s.encode() for s in split(path.read_text(encoding="utf-8"))]
    return seeds or [b"SELECT mean(x) FROM m WHERE time > now() - 1s GROUP BY time(1s)"]


RMV_WORDS = ("system", "topic", "var", "event", "when", "property", "alert", "transducer",
             "always", "eventually", "since", "until", "duration", "import", "nodes", "allow",
             "qos", "rate", "->", "[<=", "s]", " and ", " or ", "not ", "=", "\"", "{", "}",
             "\n", "//", "/*", "std_msgs/msg/Float64", "mean(", "every", "database")  # fmt: skip

# The check target's limit on each solver call (`rmv check --timeout`; 5 s by
# default). z3's limit bounds its time by design: a question that reaches it is
# answered "unknown".
SOLVER_LIMIT = "0.2"
# ... and its patience: a check asks the solver about every property, and of each
# group of up to 24 properties whether one is implied by the others (23 questions,
# each up to a few calls). The first long run with the checker instrumented found,
# in 30 s, a spec of 24 such properties that took 3 s; so a check has 10 times the
# hang limit of the other targets. The fast stages alone are held to it by `fmt`
# (the parser) and `lsp` (names and types, at every edit).
CHECK_PATIENCE = 10.0

TARGETS = {t.name: t for t in [
    Target("check", "rmv check of a .rmv spec",
           _files("examples/**/*.rmv", "tests/fixtures/**/*.rmv"),
           _command(lambda p: ["check", "--timeout", SOLVER_LIMIT, str(p)], "spec.rmv"),
           RMV_WORDS, CHECK_PATIENCE),
    Target("fmt", "rmv fmt --check of a .rmv spec", _files("examples/**/*.rmv"),
           _command(lambda p: ["fmt", "--check", str(p)], "spec.rmv"), RMV_WORDS),
    Target("import", "rmv import of the thesis's YAML", _files("tests/fixtures/thesis/*.yaml"),
           _command(lambda p: ["import", str(p)], "config.yaml"),
           (": ", "- ", "\n  ", "topic", "events", "condition", "'", "&a", "*a", "!!")),
    Target("influxql", "InfluxQL conditions and statements", _influxql_seeds, _influxql,
           ("SELECT ", " FROM ", " WHERE ", " GROUP BY ", "time(", "\"", "'", " AND ", " OR ")),
    Target("tickscript", "TICKscript alerts", _files("tests/fixtures/thesis/tick_monitors/*"),
           _tickscript, ("stream", "|from()", ".measurement(", "|alert()", ".crit(", "lambda: ",
                         "'", "\"", "|window()")),
    Target("eval", "rmv eval's JSONL and CSV trace reader", _trace_seeds,
           _command(lambda p: ["eval", "--formula", "a until[<=2] b", "--trace", str(p),
                               "--all"], "trace.jsonl"),
           ('{"t": ', '"state": ', '"props": [', '"end": true', "}\n", "1e308", "NaN", "-0")),
    Target("replay-bag", "rmv replay of a ROS 1 .bag", _recording_seed("bag"), _replay("bag")),
    Target("replay-db3", "rmv replay of a rosbag2 .db3", _recording_seed("db3"), _replay("db3")),
    Target("replay-mcap", "rmv replay of a rosbag2 .mcap", _recording_seed("mcap"),
           _replay("mcap")),
    Target("ros1-decode", "the ROS 1 host's message decoder", _ros1_seed, _ros1_decoder),
]}  # fmt: skip


def scratch() -> Path:
    return Path(tempfile.mkdtemp(prefix="rmv-fuzz-"))
