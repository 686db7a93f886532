"""The C target's monitor beside the Python runtime and reelay, on the braking trace
of bench_monitor.py (four states at 100 Hz, each held 0.05-3 s).

Per sample: every sample of the trace is stepped (a repeat only moves the known
end). Per change: the change points only, as dense-time monitors take their input.
Each tool gets the same input in the same run, its verdicts are compared before a
speed is printed (a disagreement ends the benchmark with exit status 1), and each
figure is the best of --repeat runs, timed inside the process (the C monitor by
clock_gettime around its loop, made and read before and after). The memory the
build states is printed beside the peak resident memory `/usr/bin/time -v`
measures for the C program, less that of the same program reading the same trace
without touching the monitor.

    python benchmarks/bench_c.py [--samples 1000000] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from fractions import Fraction
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from bench_monitor import (
    FORMULAS,
    REELAY,
    VARIABLES,
    Disagreement,
    change_points,
    compare_dense,
    compiled,
    generate,
    reelay,
    reelay_dense,
    steps_of_segments,
)
from c_harness import STRICT, compiler

from rmvdsl.runtime.rmtld3 import Monitor, merge
from rmvdsl.targets.c.generate import files, laid_out
from rmvdsl.targets.c.model import TICKS_PER_SECOND, changes_bound, compile_formula, sized

NS = 1_000_000_000
# The harness: samples from a binary file (int64 time, uint8 state), stepped in a
# loop timed by the monotonic clock; the segments printed after the clock stops.
HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "rmv_bench.h"

#define MAX_SEGMENTS 1000000
static rmv_segment segments[MAX_SEGMENTS];
static long count;
static rmv_bench_monitor monitor;

static void keep(void *context, int32_t property, const rmv_segment *s) {
    (void)context;
    (void)property;
    if (count < MAX_SEGMENTS) segments[count++] = *s;
}

int main(int argc, char **argv) {
    FILE *in = fopen(argv[1], "rb");
    long n = 0, k, repeat = atol(argv[2]), r;
    int monitored = argc < 4 || atoi(argv[3]);  /* 0: the baseline, no monitor touched */
    int64_t *times;
    unsigned char *states;
    rmv_bench_input inputs[RMV_BENCH_PROPOSITIONS + 1];
    double best = 1e30;
    int64_t end;
    if (!in || fread(&n, sizeof n, 1, in) != 1 || fread(&end, sizeof end, 1, in) != 1) return 2;
    times = malloc((size_t)(n ? n : 1) * sizeof *times);
    states = malloc((size_t)(n ? n : 1));
    if (fread(times, sizeof *times, (size_t)n, in) != (size_t)n) return 2;
    if (fread(states, 1, (size_t)n, in) != (size_t)n) return 2;
    for (k = 0; k <= RMV_BENCH_PROPOSITIONS; k++) {  /* k holds alone; the last: none */
        int p;
        for (p = 0; p < RMV_BENCH_PROPOSITIONS; p++) {
            inputs[k].holds[p] = (unsigned char)(p == k);
            inputs[k].pulses[p] = 0;
        }
    }
    for (r = 0; monitored && r < repeat; r++) {
        struct timespec a, b;
        double seconds;
        count = 0;
        rmv_bench_init(&monitor, keep, NULL);
        clock_gettime(CLOCK_MONOTONIC, &a);
        for (k = 0; k < n; k++) rmv_bench_step(&monitor, &inputs[states[k]], times[k]);
        rmv_bench_end(&monitor, end);
        clock_gettime(CLOCK_MONOTONIC, &b);
        seconds = (double)(b.tv_sec - a.tv_sec) + (double)(b.tv_nsec - a.tv_nsec) * 1e-9;
        if (seconds < best) best = seconds;
    }
    printf("%.9f %ld %lu %lu\n", best, count, (unsigned long)rmv_bench_overflows(&monitor, 0),
           (unsigned long)sizeof monitor);
    for (k = 0; k < count; k++)
        printf("%lld %lld %d %d %d\n", (long long)segments[k].from_ns, (long long)segments[k].to_ns,
               segments[k].from_closed, segments[k].to_closed, (int)segments[k].value);
    return 0;
}
"""
NAMES = {0: "false", 1: "unknown", 2: "true"}


def build_harness(folder: Path, formula: Any) -> tuple[Path, list[str], int]:
    """The C build of one formula and the harness, compiled -O2: the program, the
    propositions in the order its inputs index them, and the bytes its monitor
    holds. Pools are sized for a change at every sample (one a second here:
    bench_monitor's formulas count time in ticks of 10 ms)."""
    from rmvdsl.targets.c.generate import memory_bytes

    table = compile_formula(formula)
    bound = changes_bound(Fraction(1), table.horizon)
    system = laid_out("bench", [("F", "bench", sized(table, bound), 0)])
    for name, text in files(system).items():
        (folder / name).write_text(text)
    (folder / "harness.c").write_text(HARNESS)
    program = folder / "harness"
    subprocess.run(
        [
            compiler() or "cc",
            *STRICT,
            "-O2",
            "-o",
            str(program),
            str(folder / "harness.c"),
            str(folder / "rmv_bench.c"),
        ],
        check=True,
    )
    return program, list(system.propositions), memory_bytes(system)


def write_samples(path: Path, samples: list[tuple[int, str]], end: int, names: list[str]) -> None:
    """Times in nanoseconds (a tick is a second to the C monitor), each state as the
    index of the proposition that holds (or the last input: none of them)."""
    index = {name: k for k, name in enumerate(names)}
    with path.open("wb") as out:
        out.write(struct.pack("<qq", len(samples), end * NS))
        out.write(struct.pack(f"<{len(samples)}q", *(t * NS for t, _ in samples)))
        out.write(bytes(index.get(state, len(names)) for _, state in samples))


def run_c(program: Path, data: Path, repeat: int) -> tuple[float, list[tuple]]:
    done = subprocess.run(
        [str(program), str(data), str(repeat)], capture_output=True, text=True, check=True
    )
    head, *rows = done.stdout.splitlines()
    seconds, _, overflows, _ = head.split()
    if int(overflows):
        raise Disagreement("the C monitor overflowed its pools")
    segments = []
    for row in rows:
        a, b, ac, bc, v = (int(x) for x in row.split())
        segments.append((Fraction(a, NS), Fraction(b, NS), bool(ac), bool(bc), NAMES[v]))
    return float(seconds), merge(segments)


def run_python(
    formula: Any, samples: list[tuple[int, str]], end: int, repeat: int
) -> tuple[float, list]:
    inputs = [(t, frozenset({state})) for t, state in samples]
    best, out = float("inf"), []
    for _ in range(repeat):
        monitor = Monitor(formula)
        start = time.perf_counter()
        monitor.feed(inputs)
        monitor.end(end)
        out = list(monitor.verdicts())
        best = min(best, time.perf_counter() - start)
    return best, merge(out)


def run_reelay(
    pattern: str, points: list[tuple[int, str]], end: int, repeat: int
) -> tuple[float, Any]:
    rows = [
        {"time": t, **{s: s == state for s in VARIABLES.values()}}
        for t, state in [*points, (end, points[-1][1])]
    ]
    best, out = float("inf"), []
    for _ in range(repeat):
        monitor = reelay.dense_timed_monitor(pattern=pattern)
        start = time.perf_counter()
        out = reelay_dense(monitor, rows)
        best = min(best, time.perf_counter() - start)
    return best, out


def peak_rss_kb(program: Path, data: Path, monitored: bool) -> int:
    command = [str(program), str(data), "1", "1" if monitored else "0"]
    done = subprocess.run(
        ["/usr/bin/time", "-v", *command], capture_output=True, text=True, check=True
    )
    for line in done.stderr.splitlines():
        if "Maximum resident set size" in line:
            return int(line.split(":")[1])
    raise RuntimeError("no peak memory in /usr/bin/time -v's report")


def section(name: str, trace: list[tuple[int, str]], repeat: int, folder: Path) -> dict[str, Any]:
    formula = compiled(name)
    end = trace[-1][0] + 1
    program, names, declared = build_harness(folder, formula)
    row: dict[str, Any] = {"formula": FORMULAS[name], "declared_bytes": declared}
    for mode, samples in (("per sample", trace), ("per change", change_points(trace))):
        data = folder / f"{mode.replace(' ', '_')}.bin"
        write_samples(data, samples, end, names)
        c_seconds, c_segments = run_c(program, data, repeat)
        py_seconds, py_segments = run_python(formula, samples, end, repeat)
        if c_segments != py_segments:
            raise Disagreement(f"{name}, {mode}: the C monitor and the Python runtime differ")
        entry = {
            "samples": len(samples),
            "c_per_s": len(samples) / c_seconds,
            "python_per_s": len(samples) / py_seconds,
            "c_over_python": py_seconds / c_seconds,
            "false_segments": sum(1 for s in c_segments if s[4] == "false"),
        }
        if mode == "per change" and name in REELAY and reelay is not None:
            r_seconds, r_out = run_reelay(REELAY[name], samples, end, repeat)
            reelay_steps = ([float(o["time"]) for o in r_out], [o["value"] for o in r_out], end)
            compare_dense({"rmvdsl": steps_of_segments(c_segments), "reelay": reelay_steps}, {})
            entry["reelay_per_s"] = len(samples) / r_seconds
            entry["c_over_reelay"] = r_seconds / c_seconds
        row[mode] = entry
        if mode == "per sample":  # the monitor's pages: with it run, less without
            row["measured_bytes"] = 1024 * (
                peak_rss_kb(program, data, True) - peak_rss_kb(program, data, False)
            )
    return row


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args()
    if compiler() is None or not shutil.which("/usr/bin/time"):
        print("needs gcc and /usr/bin/time", file=sys.stderr)
        return 2
    trace = generate(args.samples)
    rows = {}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for name in FORMULAS:
                folder = Path(tmp) / name.replace(" ", "_")
                folder.mkdir()
                rows[name] = section(name, trace, args.repeat, folder)
    except Disagreement as exc:
        print(f"the monitors disagree, so no speed is reported: {exc}", file=sys.stderr)
        return 1
    print(
        f"{args.samples:,} samples ({len(change_points(trace)):,} change points),"
        f" best of {args.repeat}"
    )
    print(
        f"{'formula':<13}{'mode':<12}{'C /s':>16}{'Python /s':>14}{'C/Python':>10}{'reelay /s':>13}"
        f"{'C/reelay':>10}{'declared':>12}{'measured':>12}"
    )
    for name, row in rows.items():
        for mode in ("per sample", "per change"):
            e = row[mode]
            reelay_cells = (
                f"{e['reelay_per_s']:>13,.0f}{e['c_over_reelay']:>9.1f}x"
                if "reelay_per_s" in e
                else f"{'-':>13}{'-':>10}"
            )
            memory = (
                f"{row['declared_bytes']:>12,}{row['measured_bytes']:>12,}"
                if mode == "per sample"
                else ""
            )
            print(
                f"{name:<13}{mode:<12}{e['c_per_s']:>16,.0f}{e['python_per_s']:>14,.0f}"
                f"{e['c_over_python']:>9.1f}x{reelay_cells}{memory}"
            )
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "samples": args.samples,
                    "repeat": args.repeat,
                    "ticks_per_second": TICKS_PER_SECOND,
                    "rows": rows,
                },
                indent=2,
            )
            + "\n"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
