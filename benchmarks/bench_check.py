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

Machines here are shared and noisy, so the figures are ratios to `bare` in the
same run, each the best of --repeat runs (the first check: one run). Targets:
names <= 3x bare, types <= 3x names (issue 3), lower + dump <= 1x bare (the
resolved spec costs less than reading the spec); issue 15: the cached check <= 3x
bare at every scale, the 10x spec <= 11x the 1x spec for both the cached and the
first check, and the first check of the 1x spec <= 10 s on 2 cores.

    python benchmarks/bench_check.py            # scales 1, 3 and 10
    python benchmarks/bench_check.py --scale 1 --repeat 3 --json out.json
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rmvdsl.cache import Cache, use_cache
from rmvdsl.check import check
from rmvdsl.check.loader import load
from rmvdsl.check.names import check_names
from rmvdsl.check.types import TypeConfig, check_types
from rmvdsl.grammar.parser import bare_spec_parser
from rmvdsl.ir import dump, lower


def generate(scale: int = 1) -> str:
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
        names = [f"S{d}_{s}" for s in range(states)]
        lines.append(f"transducer D{d} {{")
        lines.append("    states " + ", ".join(names))
        lines.append(f"    initial {names[0]}")
        for s in range(states):
            lines.append(
                f"    {names[s]} -> {names[(s + 1) % states]} on B{(d * states + s) % bool_events}"
            )
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


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--scale", type=int, action="append", help="spec sizes (default: 1 and 10)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = parser.parse_args()
    scales = args.scale or [1, 3, 10]
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
