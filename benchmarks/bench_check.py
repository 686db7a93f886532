"""Parse and name-check cost against lark's bare parse of the same text.

Generates a large valid spec (at scale 1: 1,000 topics, 5,000 variables, 2,000
events, 100 transducers of 20 states, 500 properties), then times in one run:

- bare:   lark alone (same grammar, LALR, builds its own parse tree);
- parse:  rmvdsl's parser (per-declaration recovery, AST with spans);
- names:  the name check alone, on the parsed specs;
- types:  the type check alone (message definitions, paths, expressions, horizons);
- check:  parse + name check + type check + analyses, what `rmv check` does, with
          the property analyses answered from the solver cache (re-checking an
          unchanged spec, as the editor does); `first` is the same check with an
          empty cache, all the solver work included, with a worker process a core
          (bench_sat.py measures it per question); `alone` the first check with
          no worker (`--jobs 1`), at scale 1;
- lower:  the checked spec lowered to its resolved spec (rmvdsl.ir); `dump` the
          same and its JSON text (what `rmv build --target ir` adds to a check).

By default it measures `rmv check` as users run it: each figure a new process
(`--processes`, the default; `--in-process` gives the tables below), paired round
by round with lark's bare parse of the same file as a new process, medians of
--runs rounds (CPU seconds of the child, steadier than wall on a shared machine):

- warm:  `rmv check large.rmv` again, its inputs unchanged, after a first check
         filled the caches (issue 38: <= 2x bare at every scale);
- edit:  one line of the spec changed before each run (a comment appended), the
         solver's answers cached (issue 38: <= 3x bare);
- cold:  the first check with empty caches (--cold-runs of them, each paired
         with a bare parse run just before it: `cold_ratio` is the median of
         their wall ratios); `varied` the same of the spec whose transducers are
         all different (generate(varied=True): every solver question asked,
         none shared).

In process (`--in-process`): machines here are shared and noisy, so the figures
are ratios to `bare` in the same run, each the best of --repeat runs (the first
check: one run). Targets:
names <= 3x bare, types <= 3x names (issue 3), lower + dump <= 1x bare (the
resolved spec costs less than reading the spec); issue 15: the cached check <= 3x
bare at every scale, the 10x spec <= 11x the 1x spec for both the cached and the
first check, and the first check of the 1x spec <= 10 s on 2 cores.

    python benchmarks/bench_check.py --runs 3 --cold-runs 2 --json benchmarks/results/check_cli.json
    python benchmarks/bench_check.py --in-process --scale 1 --repeat 3 --json out.json
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from as_installed import byte_compile

from rmvdsl.check import check
from rmvdsl.check.loader import load
from rmvdsl.check.names import check_names
from rmvdsl.check.types import TypeConfig, check_types
from rmvdsl.grammar.grammars import bare_spec_parser
from rmvdsl.ir import dump, lower
from rmvdsl.util.cache import Cache, use_cache


def generate(scale: int = 1, varied: bool = False) -> str:
    """The spec at `scale`. Its transducers are alike (a ring of 20 states each, so
    the solver's questions on their properties are alike up to names, and asked
    once: rmvdsl.logic.canonical); `varied` gives each 16 to 25 states, the last
    leading back to one of the first 16 (160 shapes: at scale 1 no two transducers
    are alike, so every question is asked)."""
    topics, variables, events = 1000 * scale, 5000 * scale, 2000 * scale
    transducers, states, properties = 100 * scale, 20, 500 * scale
    lines = ["system large", "time unit s", 'messages "msg"', ""]
    for t in range(topics):
        lines.append(f'topic T{t}: pkg_msgs/Msg{t % 50} = "/robot{t % 10}/sensor{t}"')
    for v in range(variables):
        lines.append(f"var V{v} = T{v % topics}.field{v % 7}.value")
    value_events = events // 2
    for e in range(value_events):
        lines.append(f"event E{e} = mean(V{e}) * 3.6 + max(V{e + value_events})")
        lines.append("    group by time(100ms)")
        lines.append("    fill previous")
    for b in range(events - value_events):
        lines.append(f"event B{b} when V{2 * value_events + b} > 0.8 and E{b % value_events} < 5")
    for v in range(events + value_events, variables):
        lines.append(f"alert A{v} {{ warn when V{v} > 10 reset when V{v} < 5 }}")
    bool_events = events - value_events
    for d in range(transducers):
        # varied: 16 to 25 states, the last leading back to one of the first 16
        count, back = (16 + d % 10, (d // 10) % 16) if varied else (states, 0)
        names = [f"S{d}_{s}" for s in range(count)]
        lines.append(f"transducer D{d} {{")
        lines.append("    states " + ", ".join(names))
        lines.append(f"    initial {names[0]}")
        for s in range(count):
            target = s + 1 if s + 1 < count else back
            lines.append(f"    {names[s]} -> {names[target]} on B{(d * states + s) % bool_events}")
        lines.append("}")
    for p in range(properties):
        d, k = p % transducers, p // transducers  # distinct: none implies another
        a, b = f"S{d}_{k % states}", f"S{d}_{(k + 1) % states}"
        lines.append(
            f"property P{p}: ({a} -> eventually[<=10s] {b}) and duration[10s]({a}) < 4s"
            " { rate = 10Hz }"
        )
    for t in range(topics):
        lines.append(
            f'whitelist T{t} {{ publishers: "/driver{t % 10}"'
            ' subscribers: "/rmv_monitor", "/rviz*" }'
        )
    return "\n".join(lines) + "\n"


def write_messages(folder: str) -> None:
    """The 50 message types of the generated spec, each with fields field0..field6."""
    package = os.path.join(folder, "msg", "pkg_msgs", "msg")
    os.makedirs(package, exist_ok=True)
    with open(os.path.join(package, "Value.msg"), "w", encoding="utf-8") as handle:
        handle.write("float64 value\nstring unit\n")
    for index in range(50):
        with open(os.path.join(package, f"Msg{index}.msg"), "w", encoding="utf-8") as handle:
            handle.write("Header header\n")
            handle.writelines(f"Value field{f}\n" for f in range(7))


def best_of(repeat: int, action: Callable[[], object]) -> float:
    times = []
    for _ in range(repeat):
        gc.collect()
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return min(times)


def measure(scale: int, repeat: int, folder: str) -> dict[str, float]:
    text = generate(scale)
    path = os.path.join(folder, "large.rmv")
    bare = bare_spec_parser()
    loaded = load(path, text)
    assert not loaded.diagnostics, loaded.diagnostics[:3]
    alone = None
    if scale == 1:  # the same first check with no worker process, in its own cache
        use_cache(Cache(os.path.join(folder, f"alone{scale}")))
        started = time.perf_counter()
        check(path, text, use_environment=False, solver_jobs=1)
        alone = time.perf_counter() - started
    use_cache(Cache(os.path.join(folder, f"cache{scale}")))
    started = time.perf_counter()
    result = check(path, text, use_environment=False)
    first = time.perf_counter() - started
    assert not result.diagnostics, result.diagnostics[:3]

    def types() -> None:
        model, _ = check_names(loaded.specs, loaded.sources)
        check_types(model, TypeConfig(use_environment=False), folder)

    return {
        "lines": text.count("\n"),
        "bytes": len(text),
        "bare": best_of(repeat, lambda: bare.parse(text, start="start")),
        "parse": best_of(repeat, lambda: load(path, text)),
        "names": best_of(repeat, lambda: check_names(loaded.specs, loaded.sources)),
        # the type stage needs a model: its time is (names + types) - names
        "types": best_of(repeat, types),
        "check": best_of(repeat, lambda: check(path, text, use_environment=False)),
        "first": first,
        "alone": alone,
        # the resolved spec: lowering the checked spec, and its JSON
        "lower": best_of(repeat, lambda: lower(result)),
        "dump": best_of(repeat, lambda: dump(lower(result))),
    }


BARE = (
    "import sys; from rmvdsl.grammar.grammars import bare_spec_parser; "
    "bare_spec_parser().parse(open(sys.argv[1], encoding='utf-8').read(), start='start')"
)


def child(command: list[str], folder: str, cache: str) -> tuple[float, float]:
    """Wall and CPU seconds of one new process (CPU: its user + system time)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    run = subprocess.run(command, cwd=folder, capture_output=True, text=True,
                         env={**os.environ, "RMV_CACHE_DIR": cache})  # fmt: skip
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def rmv() -> list[str]:
    beside = Path(sys.executable).parent / "rmv"
    return [str(beside)] if beside.exists() else [sys.executable, "-m", "rmvdsl.cli"]


def processes(scale: int, runs: int, cold_runs: int, folder: str) -> dict[str, object]:
    """`rmv check` as new processes at one scale (see the module's docstring)."""
    text = generate(scale)
    spec = os.path.join(folder, f"large{scale}.rmv")
    Path(spec).write_text(text, encoding="utf-8")
    check_spec = [*rmv(), "check", os.path.basename(spec)]
    bare_spec = [sys.executable, "-c", BARE, os.path.basename(spec)]
    varied = os.path.join(folder, f"varied{scale}.rmv")
    Path(varied).write_text(generate(scale, varied=True), encoding="utf-8")
    check_varied = [*rmv(), "check", os.path.basename(varied)]
    cold, cold_varied, cold_bare = [], [], []
    for run in range(cold_runs):
        empty = os.path.join(folder, f"cold{scale}-{run}")
        cold_bare.append(child(bare_spec, folder, empty))  # the baseline of this round
        cold.append(child(check_spec, folder, empty))
        cold_varied.append(child(check_varied, folder, empty + "-varied"))
        print(f"  {scale}x cold run {run + 1}: {cold[-1][0]:.1f} s wall, "
              f"varied {cold_varied[-1][0]:.1f} s", file=sys.stderr)  # fmt: skip
    cache = os.path.join(folder, f"warm{scale}")
    child(check_spec, folder, cache)  # fills the caches
    rounds: dict[str, list[tuple[float, float]]] = {"bare": [], "warm": [], "edit": []}
    for run in range(runs):
        rounds["bare"].append(child(bare_spec, folder, cache))
        rounds["warm"].append(child(check_spec, folder, cache))
        with open(spec, "a", encoding="utf-8") as handle:
            handle.write(f"// edit {run}\n")  # one line more: the stored output is stale
        rounds["edit"].append(child(check_spec, folder, cache))
    figures: dict[str, object] = {"lines": text.count("\n"), "runs": runs}
    for name, pairs in rounds.items():
        figures[f"{name}_wall"] = statistics.median(w for w, _ in pairs)
        figures[f"{name}_cpu"] = statistics.median(c for _, c in pairs)
    for name in ("warm", "edit"):
        ratios = [c / b for (_, c), (_, b) in zip(rounds[name], rounds["bare"], strict=True)]
        figures[f"{name}_ratio"] = statistics.median(ratios)
    if cold:
        figures["cold_wall"] = statistics.median(w for w, _ in cold)
        figures["cold_cpu"] = statistics.median(c for _, c in cold)
        figures["cold_varied_wall"] = statistics.median(w for w, _ in cold_varied)
        figures["cold_varied_cpu"] = statistics.median(c for _, c in cold_varied)
        figures["cold_bare_wall"] = statistics.median(w for w, _ in cold_bare)
        pairs = zip(cold, cold_varied, cold_bare, strict=True)
        ratios = [(w / b, v / b) for (w, _), (v, _), (b, _) in pairs]
        figures["cold_ratio"] = statistics.median(r for r, _ in ratios)
        figures["cold_varied_ratio"] = statistics.median(r for _, r in ratios)
        figures["cold_runs"] = len(cold)
    return figures


def processes_table(results: dict[int, dict[str, object]]) -> None:
    print(f"{'scale':>5} {'lines':>7} {'bare cpu':>9} {'warm cpu':>9} {'warm/bare':>9} "
          f"{'edit cpu':>9} {'edit/bare':>9} {'cold wall':>9} {'varied':>9}")  # fmt: skip
    for scale, f in results.items():
        colds = ("cold_wall", "cold_varied_wall")
        cold = [f"{f[k]:>9.1f}" if k in f else f"{'-':>9}" for k in colds]
        print(f"{scale:>5} {f['lines']:>7} {f['bare_cpu']:>9.3f} {f['warm_cpu']:>9.3f} "
              f"{f['warm_ratio']:>9.2f} {f['edit_cpu']:>9.3f} {f['edit_ratio']:>9.2f} "
              f"{' '.join(cold)}")  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--scale", type=int, action="append", help="spec sizes (default: 1 and 10)")
    parser.add_argument("--repeat", type=int, default=3, help="--in-process: best of N")
    parser.add_argument("--in-process", action="store_true", help="the in-process tables")
    parser.add_argument("--runs", type=int, default=5, help="paired rounds of new processes")
    parser.add_argument("--cold-runs", type=int, default=1, help="first checks, empty caches")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = parser.parse_args()
    byte_compile()  # as an install holds rmvdsl: compiled
    scales = args.scale or [1, 3, 10]
    if not args.in_process:
        folder = tempfile.mkdtemp(prefix="rmv-bench-")
        write_messages(folder)
        found = {s: processes(s, args.runs, args.cold_runs, folder) for s in scales}
        processes_table(found)
        if args.json:
            Path(args.json).write_text(json.dumps(found, indent=2), encoding="utf-8")
        shutil.rmtree(folder, ignore_errors=True)
        return 0
    folder = tempfile.mkdtemp(prefix="rmv-bench-")
    os.environ["RMV_CACHE_DIR"] = os.path.join(folder, "cache")  # not the user's cache
    write_messages(folder)
    results = {
        scale: measure(scale, args.repeat if scale == 1 else max(1, args.repeat - 1), folder)
        for scale in scales
    }
    for figures in results.values():
        figures["types"] = max(0.0, figures["types"] - figures["names"])
    columns = ("bare", "parse", "names", "types", "check", "first", "lower", "dump")
    ratios = f" {'parse/bare':>10} {'names/bare':>10} {'check/bare':>10} {'types/names':>11}"
    ratios += f" {'dump/bare':>9}"
    print(f"{'scale':>5} {'lines':>8} " + " ".join(f"{c + ' s':>8}" for c in columns) + ratios)
    for scale, f in results.items():
        print(f"{scale:>5} {f['lines']:>8} " + " ".join(f"{f[c]:>8.3f}" for c in columns)
              + f" {f['parse'] / f['bare']:>10.2f} {f['names'] / f['bare']:>10.2f}"
              f" {f['check'] / f['bare']:>10.2f} {f['types'] / f['names']:>11.2f}"
              f" {f['dump'] / f['bare']:>9.2f}")  # fmt: skip
    if 1 in results:
        first, alone = results[1]["first"], results[1]["alone"]
        print(f"first check of the 1x spec: {first:.1f} s (target <= 10 s); "
              f"with no worker process {alone:.1f} s ({alone / first:.2f}x)")  # fmt: skip
    for scale in (s for s in results if s != 1 and 1 in results):
        for column in ("check", "first"):
            growth = results[scale][column] / results[1][column]
            print(f"{column} time of the {scale}x spec / the 1x spec: {growth:.2f} "
                  f"(target <= {1.1 * scale:g})")  # fmt: skip
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
