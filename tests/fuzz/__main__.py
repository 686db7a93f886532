"""`python -m tests.fuzz TARGET --runs N`: fuzz one entry point (or `all`, one
process each) with atheris, coverage-guided (libFuzzer), where atheris installs;
else with hypothesis over mutated seeds. Prints one line per target and, with
`--json FILE`, writes inputs, crashes, hangs and peak memory (docs/robustness.md).

A crash or hang is written to tests/fixtures/fuzz/<target>/ (atheris's artifact,
named by its hash): tests/test_fuzz.py replays every file there."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
# tests/ (conftest, lsp_wire, fleet_recordings). Not the checkout's root: started as
# a script (how the harness starts its children), rmvdsl is the installed one.
sys.path.insert(0, str(HERE.parent))

from fuzz import targets as known  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.fuzz", description=__doc__)
    parser.add_argument("target", choices=[*known.TARGETS, "lsp", "all"])
    parser.add_argument("--runs", type=int, default=1000, help="inputs per target")
    parser.add_argument("--seconds", type=int, default=0, help="at most this long per target")
    parser.add_argument("--timeout", type=float, default=1.0,
                        help="an input running longer is a hang (seconds)")  # fmt: skip
    parser.add_argument("--jobs", type=int, default=1, help="targets fuzzed at once (all)")
    parser.add_argument("--engine", choices=["auto", "atheris", "hypothesis"], default="auto")
    parser.add_argument("--instrument", choices=["all", "reached"], default="all",
                        help="atheris: every rmvdsl module (12 s a target), or those the "
                             "target's seeds reach")  # fmt: skip
    parser.add_argument("--json", type=Path, help="write the results here")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)  # its scratch folder
    args = parser.parse_args(argv)
    if args.child:
        return _child(args)
    names = [*known.TARGETS, "lsp"] if args.target == "all" else [args.target]
    results = _run_all(names, args)
    for result in results:
        print(_line(result))
    if args.json:
        total = {k: sum(r[k] for r in results) for k in ("inputs", "crashes", "hangs")}
        document = {"command": "python -m tests.fuzz " + " ".join(argv or sys.argv[1:]),
                    "engine": results[0]["engine"] if results else None, "targets": results,
                    "total": total, "timeout_s": args.timeout}  # fmt: skip
        args.json.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return 0 if all(r["crashes"] == r["hangs"] == 0 for r in results) else 1


def engine(wanted: str) -> str:
    if wanted != "auto":
        return wanted
    try:
        import atheris  # noqa: F401
    except ImportError:
        return "hypothesis"
    return "atheris"


def _run_all(names: list[str], args: argparse.Namespace) -> list[dict[str, Any]]:
    """Each target in a process of its own (libFuzzer ends the process it runs
    in), `--jobs` at a time."""
    pending, running, done = list(names), [], []
    while pending or running:
        while pending and len(running) < max(1, args.jobs):
            name = pending.pop(0)
            scratch = known.scratch()
            command = [sys.executable, str(HERE / "__main__.py"), name, "--child", str(scratch),
                       "--runs", str(args.runs), "--seconds", str(args.seconds),
                       "--timeout", str(args.timeout), "--engine", engine(args.engine),
                       "--instrument", args.instrument]  # fmt: skip
            started = time.monotonic()
            # libFuzzer prints a line per new input kept: a long run's output would
            # fill a pipe nobody reads until the end, and stop the child.
            output = (scratch / "output.txt").open("w+")
            process = subprocess.Popen(command, cwd=HERE.parent.parent, stdout=output,
                                       stderr=subprocess.STDOUT, text=True)  # fmt: skip
            running.append((name, process, started, scratch, output))
        time.sleep(0.2)
        for item in list(running):
            name, process, started, scratch, output = item
            if process.poll() is None:
                continue
            running.remove(item)
            output.seek(0)
            said = output.read()
            output.close()
            shutil.rmtree(scratch, ignore_errors=True)  # libFuzzer's exit skips the child's
            result = _result(name, said, process.returncode, time.monotonic() - started)
            done.append({**result, "hang_limit_s": _hang_limit(name, args.timeout)})
    return sorted(done, key=lambda r: names.index(r["target"]))


def _result(name: str, output: str, code: int, seconds: float) -> dict[str, Any]:
    """What a child said: its own JSON line, else what libFuzzer printed."""
    marker = "RMV-FUZZ-RESULT "
    for line in output.splitlines():
        if line.startswith(marker):
            found = json.loads(line[len(marker) :])
            found["seconds"] = round(seconds, 1)
            return found
    runs = re.findall(r"Done (\d+) runs", output) or re.findall(r"#(\d+)\s", output)
    peak = re.findall(r"stat::peak_rss_mb:\s*(\d+)", output) or re.findall(r"rss: (\d+)Mb", output)
    hang = "libFuzzer: timeout" in output
    # the code atheris instrumented that the inputs reached: edges, then features
    coverage = re.findall(r"cov: (\d+) ft: (\d+)", output)
    artifact = re.findall(r"Test unit written to (\S+)", output)
    crashed = code != 0 and not hang
    return {
        "target": name, "engine": "atheris", "inputs": int(runs[-1]) if runs else 0,
        "crashes": int(crashed), "hangs": int(hang), "peak_rss_mb": int(peak[-1]) if peak else None,
        "seconds": round(seconds, 1), "artifact": artifact[-1] if artifact else None,
        "edges": int(coverage[-1][0]) if coverage else None,
        "features": int(coverage[-1][1]) if coverage else None,
        "output": output[-4000:] if (crashed or hang) else "",
    }  # fmt: skip


def _line(result: dict[str, Any]) -> str:
    text = (f"{result['target']:12} {result['engine']:10} {result['inputs']:>9,} inputs  "
            f"{result['crashes']} crashes  {result['hangs']} hangs  "
            f"peak {result['peak_rss_mb']} MB  {result['seconds']} s")  # fmt: skip
    if result.get("artifact"):
        text += f"\n  written to {result['artifact']}"
    if result.get("output"):
        text += "\n" + result["output"]
    return text


# ---- in the child: one target ----


def _child(args: argparse.Namespace) -> int:
    os.environ.update(known.ENVIRONMENT)
    scratch = args.child
    target = _target(args.target)
    seeds = target.seeds(scratch) if target else []
    if args.engine == "atheris":
        return _with_atheris(args, target, seeds, scratch)
    from fuzz.mutating import run_hypothesis

    prepare = target.prepare if target else _lsp_prepare
    args.timeout = _hang_limit(args.target, args.timeout)
    result = run_hypothesis(args.target, prepare(_folder(scratch / "work")), seeds, args)
    print("RMV-FUZZ-RESULT " + json.dumps(result), flush=True)
    return 0 if result["crashes"] == result["hangs"] == 0 else 1


def _target(name: str) -> known.Target | None:
    return known.TARGETS.get(name)


def _lsp_prepare(folder: Path) -> Any:
    from fuzz import lsp

    return lsp.prepare(folder)


def _with_atheris(
    args: argparse.Namespace, target: known.Target | None, seeds: list[bytes], scratch: Path
) -> int:
    import atheris

    # A target with no seeds of its own (lsp) starts from one of mixed bytes.
    seeds = seeds or [b"\x00" * 8 + b"\x03\x10\x05\x07\x03\x20\x10\x04"]
    with atheris.instrument_imports(include=["rmvdsl", "fuzz"]):
        if args.instrument == "all":
            _import_everything()
        one = (target.prepare if target else _lsp_prepare)(_folder(scratch / "work"))
        if args.instrument == "reached":
            _reach(one, seeds)
    corpus = _folder(scratch / "corpus")
    for number, seed in enumerate(seeds):
        (corpus / f"seed{number:04d}").write_bytes(seed)
    artifacts = _folder(known.REGRESSIONS / args.target)
    hang = max(1, round(_hang_limit(args.target, args.timeout)))
    flags = [f"-runs={args.runs}", f"-timeout={hang}",
             "-rss_limit_mb=4096", "-print_final_stats=1", "-max_len=8192",
             f"-artifact_prefix={artifacts}/", str(corpus)]  # fmt: skip
    if args.seconds:
        flags.insert(0, f"-max_total_time={args.seconds}")
    if target and target.words:
        words = scratch / "words.dict"
        words.write_text("".join(f'"{_dict_escaped(w)}"\n' for w in target.words))
        flags.insert(0, f"-dict={words}")
    atheris.Setup([sys.argv[0], *flags], one)
    atheris.Fuzz()  # ends the process
    return 0


def _hang_limit(name: str, timeout: float) -> float:
    """Seconds over which an input of target `name` counts as a hang."""
    target = _target(name)
    return timeout * (target.patience if target else 1.0)


def _dict_escaped(word: str) -> str:
    """A libFuzzer dictionary entry's text: printable ASCII but the quote and the
    backslash as is, every other byte as \\xNN."""
    return "".join(
        chr(b) if 32 <= b < 127 and b not in (34, 92) else f"\\x{b:02x}" for b in word.encode()
    )


def _reach(one: Any, seeds: list[bytes]) -> None:
    """Each seed run once, so that the modules it imports (the CLI imports a
    command's modules when it runs) are imported inside the instrumentation. A
    failure is libFuzzer's to report: it runs the seeds first."""
    for seed in seeds:
        with contextlib.suppress(Exception):  # libFuzzer finds it again and writes it
            one(seed)


def _import_everything() -> None:
    """Every module of rmvdsl, imported inside the instrumentation: atheris
    instruments a module when it is first imported, and the CLI imports what a
    command needs only when it runs (the checker, the runtime, the readers), which
    is after the instrumentation has ended. The modules of the ROS hosts import
    rclpy or rospy, which only a ROS node's environment has."""
    import importlib
    import pkgutil

    import rmvdsl

    for module in pkgutil.walk_packages(rmvdsl.__path__, "rmvdsl."):
        try:
            importlib.import_module(module.name)
        except ImportError:
            if not module.name.startswith("rmvdsl.host."):
                raise


def _folder(path: Path) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    return path


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main())
