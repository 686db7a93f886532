"""The `rmv` command line's arguments: every command, its options and their checks (the
targets' options come from their declarations in the registry)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from rmvdsl import __version__
from rmvdsl.commands.argument_types import chunk, duration, instant, jobs, solver_seconds
from rmvdsl.lang.errors import EXIT_USAGE
from rmvdsl.runtime.wording import visible

if TYPE_CHECKING:
    from rmvdsl import targets


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, visible(f"rmv: error: {message}") + "\n")


if TYPE_CHECKING:
    Commands = argparse._SubParsersAction[_Parser]


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of `rmv`'s arguments. Given the arguments, only the command they
    name is described (a process runs one command, and describing every one, the
    targets' options loaded, was 40 ms of each start); without, or where they name
    no command (`--help`, a misspelt command), all of them."""
    parser = _Parser(
        prog="rmv",
        description="Check, format and import .rmv specifications of ROS monitors.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv check examples/carla/abs.rmv
  rmv check --format json spec.rmv
  rmv fmt --check examples/**/*.rmv
  rmv import rostopicmon.yaml rostopicver.yaml -o spec.rmv
  rmv eval --formula 'a until[<10] b' --trace run.jsonl --all
  rmv graph examples/carla/abs.rmv --format svg -o braking.svg
  rmv explain RMV200""",
    )
    parser.add_argument("--version", action="version", version=f"rmv {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    wanted = argv[0] if argv and argv[0] in _ADDERS else None
    for name, add in _ADDERS.items():
        if wanted is None or name == wanted:  # a process runs one command: one described
            add(commands)
    return parser


def _add_check(commands: Commands) -> None:
    """The arguments of `rmv check`."""
    from rmvdsl import targets

    check_parser = commands.add_parser(
        "check",
        help="check specs: syntax, names, structure",
        description="Check .rmv specs (and the files they import) and report every problem.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv check examples/carla/abs.rmv
  rmv check --strict --format sarif spec.rmv > rmv.sarif
  rmv check --ros humble --messages ~/ws/src spec.rmv
exit codes: 0 no errors, 1 errors (or warnings with --strict), 2 usage or I/O problem""",
    )
    check_parser.add_argument("files", nargs="+", metavar="FILE")
    check_parser.add_argument("--format", choices=("text", "json", "sarif"), default="text")
    check_parser.add_argument("--no-color", action="store_true", help="never colour the output")
    check_parser.add_argument("--strict", action="store_true", help="warnings fail the check")
    check_parser.add_argument(
        "--timeout",
        type=solver_seconds,
        metavar="SECONDS",
        help="time limit of each solver call on the properties (default 5, or "
        "`solver_timeout` in rmv.toml)",
    )
    check_parser.add_argument(
        "--jobs",
        type=jobs,
        metavar="N",
        help="processes answering independent solver questions at once (default: one a "
        "core, or `solver_jobs` in rmv.toml; 1: none beside rmv)",
    )
    check_parser.add_argument(
        "--witnesses",
        metavar="DIR",
        help="write, for each property, a trace where it holds and one where it fails "
        "(JSONL, replayable with `rmv eval`)",
    )
    check_parser.add_argument(
        "--target", choices=list(targets.REGISTRY),
        help="also say what this target of `rmv build` cannot build (RMV600) or leaves "
        "to another (RMV601), before anything is built",
    )  # fmt: skip
    _add_message_options(check_parser)


def _add_build(commands: Commands) -> None:
    """The arguments of `rmv build`."""
    from rmvdsl import targets

    build_parser = commands.add_parser(
        "build",
        help="generate a target from a spec (ir: the resolved spec as JSON; ros2, ros1: a "
        "package; "
        "kapacitor: InfluxDB queries and TICKscripts)",
        description="Check a spec and, when it has no errors, generate a target from its "
        "resolved model. `ir` writes the resolved spec as versioned JSON (docs/ir.md); "
        "`ros2` an ament_python package with the monitor and intrusion nodes (docs/ros2.md); "
        "`ros1` a catkin package with the same nodes on rospy (docs/ros1.md); "
        "`kapacitor` InfluxDB's schema and continuous queries and one TICKscript per alert, "
        "with a report of what only the ros2 or ros1 monitor computes (docs/kapacitor.md).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv build --target ir examples/carla/abs.rmv
  rmv build --target ir examples/carla/abs.rmv -o abs.ir.json
  rmv build --target ros2 examples/carla/abs.rmv -o src/carla_abs
  rmv build --target kapacitor examples/carla/abs.rmv -o build/kapacitor
exit codes: 0 built, 1 the spec has errors (shown on standard error), 2 usage or I/O problem""",
    )
    build_parser.add_argument("spec", metavar="SPEC")
    declared = targets.targets()
    build_parser.add_argument("--target", required=True, choices=[t.name for t in declared])
    files = ", ".join(t.name for t in declared if t.output == "file")
    folders = ", ".join(t.name for t in declared if t.output == "folder")
    build_parser.add_argument(
        "-o", "--output", metavar="OUT",
        help=f"write here ({files}: a file, default stdout; {folders}: a folder, required)",
    )  # fmt: skip
    _add_target_options(build_parser, [(t, t.options) for t in declared])
    build_parser.add_argument("--no-color", action="store_true")
    _add_message_options(build_parser)


def _add_deploy(commands: Commands) -> None:
    """The arguments of `rmv deploy`."""
    from rmvdsl import targets

    declared = targets.targets()
    deploy_parser = commands.add_parser(
        "deploy",
        help="apply a kapacitor build to InfluxDB and Kapacitor over their HTTP APIs",
        description="Apply what `rmv build --target kapacitor` wrote: the database, "
        "retention policies and continuous queries over InfluxDB's /query, the alert "
        "tasks over Kapacitor's /kapacitor/v1/tasks. Changes only what differs; removes "
        "the system's continuous queries and tasks the build no longer has. Credentials "
        "come from the environment only (docs/kapacitor.md).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv deploy --target kapacitor build/kapacitor
  rmv deploy --target kapacitor build/kapacitor --influx http://127.0.0.1:8086 --kapacitor http://127.0.0.1:9092
exit codes: 0 deployed (or nothing to change), 1 a server refused something or cannot be
reached (the message says what was applied before), 2 usage or I/O problem""",
    )  # fmt: skip
    deploy_parser.add_argument("out", metavar="OUT", help="the folder of the build")
    deployable = [t for t in declared if t.deploy is not None]
    deploy_parser.add_argument("--target", required=True, choices=[t.name for t in deployable])
    _add_target_options(deploy_parser, [(t, t.deploy_options) for t in deployable])


def _add_targets(commands: Commands) -> None:
    """The arguments of `rmv targets`."""
    commands.add_parser(
        "targets",
        help="list the targets of `rmv build`, one line each",
        description="Every target `rmv build --target NAME` can write, with what it writes, "
        "its options and its documentation page.",
    )


def _add_lsp(commands: Commands) -> None:
    """The arguments of `rmv lsp`."""
    commands.add_parser(
        "lsp",
        help="serve the language server over stdio (for editors: docs/editor.md)",
        description="The Language Server Protocol over standard input and output: the "
        "diagnostics of `rmv check` as you type, hover, go to definition, references, "
        "the outline and formatting (docs/editor.md).",
    )


def _add_replay(commands: Commands) -> None:
    """The arguments of `rmv replay`."""
    replay_parser = commands.add_parser(
        "replay",
        help="run a spec over recorded rosbags (.bag, .db3, .mcap)",
        description="Check a spec, then run it over ROS 1 .bag and ROS 2 .db3/.mcap "
        "recordings: verdicts, states, alerts and intrusions with recording times "
        "(docs/replay.md).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv replay examples/carla/abs.rmv examples/carla/recordings/braking.bag
  rmv replay examples/carla/abs.rmv examples/carla/recordings/braking_mcap --format jsonl
  rmv replay spec.rmv run.bag --from +10 --to +60 --report timeline.html
  rmv replay spec.rmv runs/ --jobs 4 --report fleet.html      (one result per recording)
  rmv replay spec.rmv long.mcap --chunk 10m                   (its chunks in parallel)
exit codes: 0 every property held and no intrusion, 1 a violation or an intrusion (or the
spec has errors), 2 usage or I/O problem, or a recording that does not match the spec
(a topic missing or of another type, a field missing, damaged or late messages)""",
    )
    replay_parser.add_argument("spec", metavar="SPEC")
    replay_parser.add_argument(
        "recordings", nargs="+", metavar="RECORDING",
        help="a .bag, .mcap or .db3 file, a rosbag2 folder, a folder to search for them, "
        "or a pattern (quoted: 'runs/**/*.bag'); several: one result each (docs/fleet.md)",
    )  # fmt: skip
    replay_parser.add_argument(
        "--from", dest="start", metavar="T", type=instant("--from"),
        help="start at T seconds on the recording's clock (+T: T after its start)",
    )  # fmt: skip
    replay_parser.add_argument(
        "--to", dest="stop", metavar="T", type=instant("--to"), help="stop at T (as --from)"
    )  # fmt: skip
    replay_parser.add_argument("--format", choices=("text", "json", "jsonl"), default="text")
    replay_parser.add_argument(
        "--report",
        metavar="FILE",
        help="draw a timeline: FILE.html (with every record), FILE.svg, or FILE.png "
        "(needs matplotlib: the report extra)",
    )
    replay_parser.add_argument(
        "--run-actions", action="store_true",
        help="really run exec, post and tcp actions (default: only report them)",
    )  # fmt: skip
    replay_parser.add_argument("--no-color", action="store_true")
    fleet = replay_parser.add_argument_group("several recordings (docs/fleet.md)")
    fleet.add_argument(
        "--jobs", type=jobs, metavar="N",
        help="replay N recordings at a time, each in a process (default: the cores)",
    )  # fmt: skip
    fleet.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="run on the Dask cluster whose scheduler is at ADDRESS (tcp://HOST:PORT; "
        "needs the fleet extra: pip install 'rmvdsl[fleet]')",
    )  # fmt: skip
    fleet.add_argument(
        "--dask", action="store_true",
        help="run on the Dask cluster whose scheduler RMV_DASK_SCHEDULER names",
    )  # fmt: skip
    fleet.add_argument(
        "--timeout", type=duration, metavar="SECONDS",
        help="give up on a recording after SECONDS (retried once, then reported failed)",
    )  # fmt: skip
    fleet.add_argument(
        "--chunk", type=chunk, metavar="DURATION",
        help="replay a recording longer than DURATION (600, 90s, 10m, 1h) in chunks that "
        "long, in parallel, joined into exactly one run's result",
    )  # fmt: skip
    fleet.add_argument(
        "--quiet", action="store_true", help="no progress on standard error"
    )  # fmt: skip
    fleet.add_argument(
        "--merge", action="store_true",
        help="read the recordings as one, merged in time order (a bag split in parts)",
    )  # fmt: skip
    _add_message_options(replay_parser)


def _add_explain(commands: Commands) -> None:
    """The arguments of `rmv explain`."""
    explain_parser = commands.add_parser(
        "explain",
        help="explain a diagnostic code",
        description="Print the explanation of a diagnostic code.",
        epilog="example: rmv explain RMV200",
    )
    explain_parser.add_argument("code", metavar="CODE")


def _add_fmt(commands: Commands) -> None:
    """The arguments of `rmv fmt`."""
    fmt_parser = commands.add_parser(
        "fmt",
        help="rewrite specs in the canonical layout",
        description="Rewrite .rmv files in the canonical layout, keeping comments.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv fmt spec.rmv            rewrite in place
  rmv fmt --check spec.rmv    exit 1 if the file would change
  rmv fmt - < spec.rmv        read standard input, write standard output""",
    )
    fmt_parser.add_argument("files", nargs="+", metavar="FILE")
    fmt_parser.add_argument(
        "--check", action="store_true", help="only report files that would change"
    )
    fmt_parser.add_argument("--no-color", action="store_true")


def _add_eval(commands: Commands) -> None:
    """The arguments of `rmv eval`."""
    eval_parser = commands.add_parser(
        "eval",
        help="evaluate an RMTLD3 formula over a trace file",
        description="Evaluate a formula (the .rmv infix form or rmtld3synth's LaTeX form) over "
        "a trace of state changes, with the online monitor. Prints true, false or unknown.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv eval --formula 'HardBraking -> eventually[<=10s] Stopped' --trace run.jsonl
  rmv eval --formula '\\int^{10} HardBraking < 4' --trace run.jsonl --at 2.5
  rmv eval --formula 'a until[<5] b' --trace run.csv --all --format json
  rmv eval --term --formula 'duration[22](p1)' --trace run.jsonl --at 2
trace lines (JSONL):
  {"t": 0, "state": "A"}  {"t": 1, "props": ["a", "b"]}  {"t": 9, "end": true}""",
    )
    eval_parser.add_argument(
        "--formula", required=True, help="the formula (quote it for the shell)"
    )
    eval_parser.add_argument("--trace", required=True, metavar="FILE", help="JSONL or CSV")
    eval_parser.add_argument("--syntax", choices=("auto", "rmv", "latex"), default="auto")
    when = eval_parser.add_mutually_exclusive_group()
    when.add_argument("--at", metavar="T", default="0", help="the evaluation time (default 0)")
    when.add_argument("--all", action="store_true", help="the verdict at every time: segments")
    eval_parser.add_argument(
        "--term", action="store_true", help="the formula is a term: print its value"
    )
    eval_parser.add_argument("--format", choices=("text", "json"), default="text")
    eval_parser.add_argument("--no-color", action="store_true")


def _add_sat(commands: Commands) -> None:
    """The arguments of `rmv sat`."""
    sat_parser = commands.add_parser(
        "sat",
        help="is a formula satisfiable? valid? (with witness traces)",
        description="""Decide whether a formula can hold (satisfiable) and whether it always
holds (valid), in dense time, with z3. Each answer is yes, no or unknown. A yes or
a no is exact and comes with a trace where one exists (a witness where the formula
is true, a counterexample where it is false), replayed through the reference
evaluator before it is shown. unknown says why: no trace with a few changes was
found and no proof either, or the time limit was hit. Bare numbers are seconds.""",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv sat --formula 'eventually[<10] p and always[<10] not p'
  rmv sat --syntax latex --formula '\\always_{<20}(a \\lor b) \\until_{<20} r'
  rmv sat --formula 'a until[<5] b' --format json
exit codes: 0 answered (whatever the answer), 1 the formula has errors, 2 usage problem""",
    )
    sat_parser.add_argument("--formula", required=True, help="the formula (quote it)")
    sat_parser.add_argument("--syntax", choices=("auto", "rmv", "latex"), default="auto")
    sat_parser.add_argument("--format", choices=("text", "json"), default="text")
    sat_parser.add_argument(
        "--timeout",
        type=solver_seconds,
        default=5.0,
        metavar="SECONDS",
        help="per solver call (5)",
    )
    sat_parser.add_argument("--no-color", action="store_true")


def _add_graph(commands: Commands) -> None:
    """The arguments of `rmv graph`."""
    graph_parser = commands.add_parser(
        "graph",
        help="draw a transducer, problems highlighted",
        description="Draw the transducers of a spec (DOT, Mermaid or SVG), with unreachable "
        "states, states with no way out and conflicting transitions highlighted.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv graph examples/carla/abs.rmv --transducer Braking --format svg -o braking.svg
  rmv graph spec.rmv | dot -Tpng > transducers.png
  rmv graph spec.rmv --format mermaid""",
    )
    graph_parser.add_argument("spec", metavar="SPEC")
    graph_parser.add_argument("--transducer", metavar="NAME", help="only this one (default: all)")
    graph_parser.add_argument("--format", choices=("dot", "mermaid", "svg"), default="dot")
    graph_parser.add_argument("-o", "--output", metavar="FILE", help="write here (default: stdout)")
    graph_parser.add_argument("--no-color", action="store_true")


def _add_import(commands: Commands) -> None:
    """The arguments of `rmv import`."""
    import_parser = commands.add_parser(
        "import",
        help="turn the thesis's YAML configurations into one .rmv spec",
        description="Convert rostopicmon / rostopicver / rostopicintrusion YAML files into one "
        ".rmv spec. What cannot be carried over is reported on standard error.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="""examples:
  rmv import config.yaml
  rmv import rostopicmon.yaml rostopicver.yaml intrusion.yaml -o carla.rmv""",
    )
    import_parser.add_argument("files", nargs="+", metavar="YAML")
    import_parser.add_argument(
        "-o", "--output", metavar="FILE", help="write here (default: stdout)"
    )
    import_parser.add_argument("--name", default=None, help="the system name of the spec")


# Each command's arguments, in the order `rmv --help` lists them.
_ADDERS: dict[str, Callable[[Commands], None]] = {
    "check": _add_check,
    "build": _add_build,
    "deploy": _add_deploy,
    "targets": _add_targets,
    "lsp": _add_lsp,
    "replay": _add_replay,
    "explain": _add_explain,
    "fmt": _add_fmt,
    "eval": _add_eval,
    "sat": _add_sat,
    "graph": _add_graph,
    "import": _add_import,
}


def _add_target_options(
    parser: argparse.ArgumentParser,
    declared: list[tuple[targets.Target, tuple[targets.Option, ...]]],
) -> None:
    """Each target's own options, as it declares them, named for the target in
    --help; an option two targets declare alike is one flag naming both."""
    helps: dict[str, dict[str, list[str]]] = {}  # flag -> help -> targets
    first: dict[str, targets.Option] = {}
    for target, options in declared:
        for option in options:
            first.setdefault(option.flag, option)
            helps.setdefault(option.flag, {}).setdefault(option.help, []).append(target.name)
    for flag, option in first.items():
        text = "; ".join(f"{', '.join(names)}: {help}" for help, names in helps[flag].items())
        parser.add_argument(
            flag, dest=option.name, metavar=option.metavar, help=text,
            choices=option.choices or None,
        )  # fmt: skip


def _add_message_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--ros",
        metavar="DISTRO",
        help="the ROS distribution whose messages apply (noetic, humble, jazzy, ...); "
        "wins over the spec's `ros`",
    )
    parser.add_argument(
        "--messages",
        metavar="DIR",
        action="append",
        default=[],
        help="a folder of .msg files (<pkg>/msg/*.msg below it); may be repeated",
    )
