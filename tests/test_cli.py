"""The `rmv` command end to end: exit codes, formats, usage errors."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest
from conftest import ROOT, rmv_process

SUBCOMMANDS = ["check", "explain", "fmt", "import"]


def test_version(rmv):
    result = rmv("--version")
    assert result.code == 0
    assert result.out.startswith("rmv 0.")


@pytest.mark.parametrize("command", SUBCOMMANDS)
def test_every_subcommand_has_help_with_examples(rmv, command):
    result = rmv(command, "--help")
    assert result.code == 0
    assert "example" in result.out


def test_no_command_prints_help_and_usage_code(rmv):
    result = rmv()
    assert result.code == 2
    assert "check" in result.out


def test_check_clean_example_prints_one_line(rmv):
    result = rmv("check", "examples/carla/abs.rmv")
    assert result.code == 0
    assert result.out.splitlines() == ["examples/carla/abs.rmv: 0 errors, 0 warnings"]


def test_check_reports_errors_with_exit_1(rmv):
    result = rmv("check", "--no-color", "examples/errors/undefined.rmv")
    assert result.code == 1
    assert "examples/errors/undefined.rmv:9:22" in result.out
    assert "did you mean `BrakePedal`?" in result.out


def test_warnings_pass_unless_strict(rmv, tmp_path):
    spec = tmp_path / "warn.rmv"
    spec.write_text('topic s: std_msgs/Float64 = "/speed"\nvar Unused = s.data\n', encoding="utf-8")
    assert rmv("check", str(spec)).code == 0
    strict = rmv("check", "--strict", str(spec))
    assert strict.code == 1
    assert "RMV203" in strict.out


def test_json_format(rmv):
    result = rmv("check", "--format", "json", "examples/errors/undefined.rmv")
    assert result.code == 1
    diagnostics = json.loads(result.out)
    keys = {
        "severity",
        "code",
        "message",
        "file",
        "line",
        "column",
        "end_line",
        "end_column",
        "labels",
        "help",
        "fixes",
    }
    assert all(set(d) == keys for d in diagnostics)
    brake = next(d for d in diagnostics if "BrakePedl" in d["message"])
    assert (brake["line"], brake["column"], brake["end_line"], brake["end_column"]) == (
        9,
        22,
        9,
        31,
    )
    assert brake["severity"] == "error" and brake["code"] == "RMV200"
    assert brake["help"] == "did you mean `BrakePedal`?"
    (fix,) = brake["fixes"]  # the did-you-mean, as an edit of the misspelt name
    assert fix["title"] == "Replace with `BrakePedal`" and fix["text"] == "BrakePedal"
    assert (fix["line"], fix["column"], fix["end_line"], fix["end_column"]) == (9, 22, 9, 31)
    assert brake["labels"][0]["primary"] is True


def test_json_labels_carry_secondary_locations(rmv):
    diagnostics = json.loads(rmv("check", "--format", "json", "examples/errors/duplicate.rmv").out)
    velocity = next(d for d in diagnostics if "`Velocity`" in d["message"])
    assert [(label["line"], label["primary"]) for label in velocity["labels"]] == [
        (10, True),
        (9, False),
    ]


def test_sarif_format(rmv):
    result = rmv("check", "--format", "sarif", "examples/errors/undefined.rmv")
    document = json.loads(result.out)
    assert document["version"] == "2.1.0"
    run = document["runs"][0]
    assert run["tool"]["driver"]["name"] == "rmv"
    rule_ids = [rule["id"] for rule in run["tool"]["driver"]["rules"]]
    assert rule_ids == sorted(set(rule_ids))
    result0 = run["results"][0]
    assert result0["ruleId"] in rule_ids
    assert rule_ids[result0["ruleIndex"]] == result0["ruleId"]
    region = result0["locations"][0]["physicalLocation"]["region"]
    assert {"startLine", "startColumn", "endLine", "endColumn"} <= set(region)
    assert {r["level"] for r in run["results"]} == {"error", "warning"}


def test_color_only_on_request_of_a_terminal(rmv):
    result = rmv("check", "examples/errors/undefined.rmv")
    assert "\033[" not in result.out  # captured output is not a terminal


@pytest.mark.parametrize(
    ("setup", "message"),
    [
        ("missing", "no such file"),
        ("directory", "is a directory"),
        ("latin1", "not UTF-8"),
    ],
)
def test_unreadable_input_is_exit_2_with_one_line(tmp_path, setup, message):
    target = tmp_path / "spec.rmv"
    if setup == "directory":
        target.mkdir()
    elif setup == "latin1":
        target.write_bytes(b"// caf\xe9\n")
    result = rmv_process(["check", str(target)])
    assert result.code == 2
    assert result.err.count("\n") == 1 and message in result.err
    assert "Traceback" not in result.err + result.out


def test_unknown_option_is_usage_error(rmv):
    result = rmv("check", "--colour", "examples/carla/abs.rmv")
    assert result.code == 2
    assert "unrecognized arguments" in result.err


def test_explain(rmv):
    result = rmv("explain", "RMV200")
    assert result.code == 0
    assert result.out.startswith("RMV200: undefined name")
    assert rmv("explain", "rmv212").code == 0
    unknown = rmv("explain", "RMV999")
    assert unknown.code == 2 and "unknown code" in unknown.err


def test_multiple_files_summary(rmv):
    result = rmv("check", "examples/carla/abs.rmv", "examples/gazebo/prius_platoon.rmv")
    assert result.code == 0
    assert result.out.strip() == "2 files: 0 errors, 0 warnings"


def test_one_missing_file_among_several_is_exit_2(rmv):
    result = rmv("check", "examples/carla/abs.rmv", "examples/nothere.rmv")
    assert result.code == 2
    assert "no such file" in result.err


def test_fmt_check_and_rewrite(rmv, tmp_path):
    spec = tmp_path / "messy.rmv"
    spec.write_text(
        'topic  s :std_msgs/Float64="/speed"   // the speed\nvar   V=s.data\n'
        "event E = mean(V) group by time(1s)  fill  none\nalert A{warn when E>3}\n",
        encoding="utf-8",
    )
    check = rmv("fmt", "--check", str(spec))
    assert check.code == 1 and "would reformat" in check.out
    assert rmv("fmt", str(spec)).code == 0
    assert spec.read_text(encoding="utf-8") == (
        'topic s: std_msgs/Float64 = "/speed"  // the speed\n'
        "var V = s.data\n"
        "event E = mean(V)\n"
        "    group by time(1s)\n"
        "    fill none\n"
        "alert A {\n"
        "    warn when E > 3\n"
        "}\n"
    )
    assert rmv("fmt", "--check", str(spec)).code == 0


def test_fmt_refuses_syntax_errors(rmv):
    result = rmv("fmt", "--check", "examples/errors/syntax.rmv")
    assert result.code == 1
    assert "fix the syntax errors first" in result.err


def test_fmt_stdin_to_stdout():
    result = rmv_process(["fmt", "-"], stdin='var  X =t.a\ntopic t: a/B = "/t"\n')
    assert result.code == 0
    assert result.out == 'var X = t.a\ntopic t: a/B = "/t"\n'


def test_fmt_loads_no_stage_of_the_checker():
    """`rmv fmt` parses and prints: the checker's stages (a fifth of its start, when
    it read files through the checker's loader) stay unloaded."""
    import subprocess

    probe = (
        "import sys\nfrom rmvdsl.cli import main\n"
        "code = main(['fmt', '--check', sys.argv[1]])\n"
        "print(code, sorted(m for m in sys.modules if m.startswith('rmvdsl.check')))\n"
    )
    spec = str(ROOT / "examples" / "carla" / "abs.rmv")
    run = subprocess.run([sys.executable, "-c", probe, spec], capture_output=True, text=True)
    assert run.stdout.strip() == "0 []", run.stdout + run.stderr


@pytest.mark.parametrize(
    ("spec", "loaded"), [("gazebo/network.rmv", False), ("carla/abs.rmv", True)]
)
def test_networkx_is_loaded_by_a_spec_with_a_transducer_alone(spec: str, loaded: bool):
    """A check of a spec with no transducer (a whitelist, alerts) makes no graph:
    networkx's import was a third of such a check's CPU after an edit."""
    import subprocess

    probe = (
        "import sys\nfrom rmvdsl.check import check\n"
        "result = check(sys.argv[1])\n"
        "print(len(result.errors), 'networkx' in sys.modules)\n"
    )
    path = str(ROOT / "examples" / spec)
    run = subprocess.run([sys.executable, "-c", probe, path], capture_output=True, text=True)
    assert run.stdout.split() == ["0", str(loaded)], run.stdout + run.stderr


def test_console_script_is_installed():
    # `pip install .` (as the README and CI do) provides the `rmv` command itself.
    import shutil
    import subprocess

    # The script pip installs stands beside this interpreter (a venv's bin folder need
    # not be on PATH); PATH is the fallback for other layouts.
    beside = Path(sys.executable).parent / "rmv"
    path = str(beside) if beside.exists() else shutil.which("rmv")
    assert path is not None, "install the project first: pip install -e '.[dev]'"

    completed = subprocess.run(
        [path, "--version"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ},
        timeout=60,
    )
    assert completed.returncode == 0 and completed.stdout.startswith("rmv ")


def test_targets_come_from_the_registry(rmv):
    """`rmv targets` and `rmv build --target` read one declaration per target."""
    from rmvdsl.targets import REGISTRY, targets

    listed = rmv("targets")
    assert listed.code == 0
    names = [line.split()[0] for line in listed.out.splitlines()]
    assert names == list(REGISTRY) == [t.name for t in targets()]
    wrong = rmv("build", "--target", "ir", "examples/carla/abs.rmv", "--package", "x")
    assert wrong.code == 2 and "--package is an option of --target ros2" in wrong.err
    missing = rmv("build", "--target", "ros2", "examples/carla/abs.rmv")
    assert missing.code == 2 and "--target ros2 needs -o OUT" in missing.err


def test_a_target_s_package_is_light_to_import():
    """The command line reads every declaration for its --help: no target's own
    import may pull in its generator (jinja2)."""
    import subprocess
    import sys

    code = (
        "import sys; from rmvdsl.targets import targets; targets(); "
        "print(sorted(m for m in sys.modules if m.startswith('jinja2') or m.endswith('.generate')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def _twelve_properties(spec: Path) -> Path:
    """A spec whose 36 solver questions go to the workers (--jobs 2)."""
    lines = [f"system {spec.stem}", 'topic t: std_msgs/msg/Float64 = "/t"', "var x = t.data"]
    lines += [f"event E{i} when x > {i}" for i in range(4)]
    lines += [f"property P{i}: E{i % 4} -> eventually[<={i % 5 + 1}s] E{(i + 1) % 4}"
              for i in range(12)]  # fmt: skip
    spec.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return spec


def test_check_shows_the_solver_s_progress_on_a_terminal(tmp_path):
    """On a terminal, solver work over RMV_PROGRESS_AFTER seconds (2 by default)
    shows a bar on standard error, redrawn in place and cleared when done; piped,
    nothing is added (every other test reads a pipe)."""
    import pty
    import subprocess

    from conftest import RMV

    spec = _twelve_properties(tmp_path / "bar.rmv")
    master, slave = pty.openpty()
    env = dict(os.environ, RMV_CACHE_DIR=str(tmp_path / "cache"), RMV_PROGRESS_AFTER="0")
    done = subprocess.Popen([*RMV, "check", "--jobs", "2", str(spec)], stdout=subprocess.PIPE,
                            stderr=slave, env=env)  # fmt: skip
    os.close(slave)
    shown = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # the other end closed
            break
        if not chunk:
            break
        shown += chunk
    out, _ = done.communicate()
    os.close(master)
    assert done.returncode == 0, out
    text = shown.decode()
    assert "\r[" in text and "solver: 1/" in text, text
    assert text.endswith("\r"), text  # the bar cleared: the terminal's line is free
    assert out.decode().strip().endswith("0 errors, 0 warnings")


def test_the_command_exits_with_its_output_and_answers_kept_and_no_worker_left(tmp_path):
    """The console script leaves without freeing the check's objects one by one
    (rmvdsl.cli.entry): what it printed, the answers its cache writer held and the
    stopping of the solver's workers must all happen before it goes."""
    import subprocess
    import time

    from conftest import RMV

    spec = _twelve_properties(tmp_path / "leaving.rmv")
    cache = tmp_path / "cache-of-this-test"
    env = dict(os.environ, RMV_CACHE_DIR=str(cache))
    done = subprocess.run([*RMV, "check", "--jobs", "2", str(spec)], capture_output=True,
                          text=True, env=env, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith("0 errors, 0 warnings") and done.stderr == ""
    answers = cache / "answers"
    assert sum(1 for f in answers.rglob("*") if f.is_file()) >= 12  # the workers' answers, kept

    def left() -> list[int]:  # processes still holding this test's cache folder
        found = []
        for pid in filter(str.isdigit, os.listdir("/proc")):
            try:
                environ = Path(f"/proc/{pid}/environ").read_bytes()
            except OSError:
                continue
            if str(cache).encode() in environ:
                found.append(int(pid))
        return found

    deadline = time.monotonic() + 10
    while left() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert left() == []


def test_the_command_says_nothing_more_into_a_closed_pipe():
    import subprocess

    from conftest import RMV

    command = " ".join([*RMV, "explain", "RMV200", "|", "head", "-c", "1"])
    done = subprocess.run(["bash", "-o", "pipefail", "-c", command], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)  # fmt: skip
    assert done.stdout == "#" or len(done.stdout) == 1
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr


def test_the_command_exits_the_usual_way_while_a_thread_it_started_runs(monkeypatch):
    """entry() skips the interpreter's teardown only when nothing is left to wait
    for; exit handlers run first, with the command's code. (The threads are the
    test's to say: a test process has threads of its own.)"""
    import threading

    from rmvdsl import cli

    ran: list[str] = []

    class Left(Exception):
        pass

    def hard_exit(code: int) -> None:
        ran.append(f"os._exit {code}")
        raise Left

    waiting = threading.Thread(target=lambda: None)  # not daemon, never started
    threads = [threading.current_thread(), threading.Thread(target=lambda: None, daemon=True)]
    monkeypatch.setattr(cli.threading, "enumerate", lambda: list(threads))
    monkeypatch.setattr(cli.atexit, "_run_exitfuncs", lambda: ran.append("handlers"))
    monkeypatch.setattr(cli.os, "_exit", hard_exit)
    monkeypatch.setattr(cli, "main", lambda: 1)
    with pytest.raises(Left):
        cli.entry()
    assert ran == ["handlers", "os._exit 1"]

    threads.append(waiting)
    ran.clear()
    with pytest.raises(SystemExit) as usual:
        cli.entry()
    assert usual.value.code == 1 and ran == []


def test_a_parser_built_for_one_command_describes_it_as_the_whole_one():
    """`rmv CMD ...` builds the parser of CMD alone (a start describing every
    command took 40 ms): its help and defaults are the whole parser's, and arguments
    naming no command (`--help`, a misspelt one) get the whole parser."""
    import argparse

    from rmvdsl.commands.arguments import _ADDERS, build_parser

    def commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        return dict(action.choices)

    whole = commands(build_parser())
    assert list(whole) == list(_ADDERS)
    for name in _ADDERS:
        alone = commands(build_parser([name, "x"]))
        assert list(alone) == [name]
        assert alone[name].format_help() == whole[name].format_help()
        assert _defaults(alone[name]) == _defaults(whole[name])
    for argv in (["--help"], ["chek"], [], ["--version"]):
        assert list(commands(build_parser(argv))) == list(_ADDERS)


def _defaults(parser) -> list[tuple]:
    return [(a.dest, a.default, a.required, a.choices) for a in parser._actions]
