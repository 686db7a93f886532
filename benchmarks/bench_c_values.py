"""The C target from values beside the Python runtime: abs.rmv's events, braking
transducer and properties over the ego vehicle's status at 100 Hz (a drive that
cruises, brakes hard, engages the ABS, stops and starts again, every 20 s).

The runtime takes each status message (an object, as rosbags decodes it) and
computes everything: the variables, the two queries over 100 ms windows, the
events, the transducer, the properties. The C monitor takes what the host gives
it (the variables, and the query the conditions read, from the runtime's own
points) and computes the events, the transducer and the properties. Their
verdicts are compared before a speed is printed (a disagreement ends the
benchmark with exit status 1). A second C build has the status topic's rate
declared (`max_rate = 200Hz`) and so computes the derivative query itself, from
Velocity: the host gives it the four fields and nothing else. Each figure is the
best of --repeat runs; the C
monitor's loop is timed inside its process by clock_gettime, the runtime's by
process_time around its loop (the same work: no start-up on either side).

    python benchmarks/bench_c_values.py [--samples 1000000] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from fractions import Fraction
from pathlib import Path
from types import SimpleNamespace
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from c_harness import STRICT, compiler, segments_by_property

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime import engine
from rmvdsl.targets.c.generate import files, system_of

ROOT = Path(__file__).resolve().parent.parent
NS = 1_000_000_000
TOPIC = "/carla/hero/vehicle_status"
PERIOD = NS // 100
# The harness: instants from a binary file (int64 time, uint8 set mask, then the
# values as doubles or bytes), updated in a loop timed by the monotonic clock.
HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "rmv_carla_abs.h"

static void show(void *context, int32_t property, const rmv_segment *s) {
    (void)context;
    printf("%d %lld %lld %d %d %d\n", (int)property, (long long)s->from_ns,
           (long long)s->to_ns, s->from_closed, s->to_closed, (int)s->value);
}

/* Every instant of the file through the monitor, then its end. */
static void run(rmv_carla_abs_monitor *monitor, const unsigned char *data, long count,
                int64_t end) {
    const long record = 8 + 1 + RMV_CARLA_ABS_VALUES * 8;
    long k;
    for (k = 0; k < count; k++) {
        const unsigned char *r = data + k * record;
        rmv_carla_abs_sample s;
        int64_t t;
        int v;
        memcpy(&t, r, 8);
        for (v = 0; v < RMV_CARLA_ABS_VALUES; v++) {
            s.set[v] = (unsigned char)((r[8] >> v) & 1);
            memcpy(&s.value[v], r + 9 + 8 * v, 8);
        }
        rmv_carla_abs_update(monitor, &s, t);
    }
    rmv_carla_abs_end(monitor, end);
}

int main(int argc, char **argv) {
    static rmv_carla_abs_monitor timed, shown;
    FILE *in = fopen(argv[1], "rb");
    long size, count;
    unsigned char *data;
    int64_t end;
    struct timespec start, stop;
    (void)argc;
    fseek(in, 0, SEEK_END);
    size = ftell(in);
    fseek(in, 0, SEEK_SET);
    data = malloc((size_t)size);
    if (fread(data, 1, (size_t)size, in) != (size_t)size) return 2;
    count = (size - 8) / (8 + 1 + RMV_CARLA_ABS_VALUES * 8);
    memcpy(&end, data + size - 8, 8);
    rmv_carla_abs_init(&timed, NULL, NULL);
    clock_gettime(CLOCK_MONOTONIC, &start);
    run(&timed, data, count, end);
    clock_gettime(CLOCK_MONOTONIC, &stop);
    fprintf(stderr, "%.9f\n", (double)(stop.tv_sec - start.tv_sec)
            + (double)(stop.tv_nsec - start.tv_nsec) / 1e9);
    /* the same run once more, its segments printed (outside the clock) */
    rmv_carla_abs_init(&shown, show, NULL);
    run(&shown, data, count, end);
    free(data);
    fclose(in);
    return 0;
}
"""


def drive(samples: int) -> list[tuple[int, float, float, bool, float]]:
    """(time, velocity, brake, hand brake, throttle) at 100 Hz: 20 s cycles of
    cruising at 20 m/s, braking hard, the ABS holding, hard again to a stop,
    standing, pulling away."""
    out = []
    for k in range(samples):
        t = (k % 2000) / 100
        if t < 8:
            velocity, brake, gas = 20.0, 0.0, 0.4
        elif t < 9.5:  # hard braking
            velocity, brake, gas = 20.0 - 7.0 * (t - 8), 0.95, 0.0
        elif t < 12:  # the ABS holds the deceleration
            velocity, brake, gas = 9.5 - 1.5 * (t - 9.5), 0.95, 0.0
        elif t < 13:  # hard again, to a stop
            velocity, brake, gas = max(0.0, 5.75 * (13 - t) - 0.05), 0.95, 0.0
        elif t < 15:
            velocity, brake, gas = 0.0, 0.5, 0.0
        else:
            velocity, brake, gas = 4.0 * (t - 15), 0.0, 0.6
        out.append((NS + k * PERIOD, velocity + 0.01 * math.sin(k), brake, False, gas))
    return out


def runtime_run(spec: Any, drive_samples: list) -> tuple[float, list[dict], list[dict]]:
    """The runtime's CPU seconds, its records (verdicts and the query's points)."""
    status = SimpleNamespace
    messages = [
        (t, status(velocity=v, control=status(brake=b, hand_brake=h, throttle=g)))
        for t, v, b, h, g in drive_samples
    ]
    runtime = engine.Runtime(spec, record=("event",))
    begin = time.process_time()
    for t, decoded in messages:
        runtime.message(t, TOPIC, decoded)
    runtime.end()
    spent = time.process_time() - begin
    records = runtime.records()
    return spent, records, [r for r in records if r["kind"] == "verdict"]


def instants(system: Any, drive_samples: list, records: list[dict]) -> bytes:
    """What the host gives the C monitor, as the harness reads it."""
    names = [s.name for s in system.flow.sources]
    kinds = {s.name: s.kind for s in system.flow.sources}
    by_time: dict[int, dict[str, Any]] = {}
    fields = {"Velocity": 1, "BrakePedal": 2, "HandBrake": 3, "GasPedal": 4}
    for sample in drive_samples:
        by_time.setdefault(sample[0], {}).update(
            {name: sample[i] for name, i in fields.items() if name in kinds}
        )
    start = drive_samples[0][0]
    for r in records:
        if r["kind"] == "event" and r["name"] in kinds and r["name"] not in fields:
            at = max(int(Fraction(r["time"]) * NS), start)
            by_time.setdefault(at, {})[r["name"]] = r["value"]
    out = bytearray()
    for t in sorted(by_time):
        values = by_time[t]
        mask = sum(1 << k for k, name in enumerate(names) if name in values)
        out += struct.pack("<qB", t, mask)
        for name in names:
            value = values.get(name, 0)
            if kinds[name] == "float":
                out += struct.pack("<d", float(value))
            elif kinds[name] == "int":
                out += struct.pack("<q", int(value))
            else:
                out += struct.pack("<B7x", int(bool(value)))
    return bytes(out + struct.pack("<q", drive_samples[-1][0]))


def c_run(folder: Path, data: bytes, names: list[str]) -> tuple[float, dict]:
    (folder / "trace.bin").write_bytes(data)
    done = subprocess.run([str(folder / "harness"), str(folder / "trace.bin")],
                          capture_output=True, text=True, check=True)  # fmt: skip
    segments = []
    for line in done.stdout.splitlines():
        prop, low, high, low_closed, high_closed, value = map(int, line.split())
        bounds = ("[" if low_closed else "(") + ("]" if high_closed else ")")
        segments.append({
            "kind": "verdict", "property": names[prop], "from": Fraction(low, NS),
            "to": Fraction(high, NS), "bounds": bounds,
            "verdict": ["false", "unknown", "true"][value],
        })  # fmt: skip
    return float(done.stderr.split()[0]), segments_by_property(segments)


def declared_spec(folder: Path) -> Any:
    """abs.rmv with its status topic's rate declared, beside its messages."""
    example = ROOT / "examples" / "carla"
    shutil.copytree(example / "msg", folder / "msg")
    text = (example / "abs.rmv").read_text(encoding="utf-8")
    text = text.replace("    depth = 10\n", "    depth = 10\n    max_rate = 200Hz\n", 1)
    (folder / "abs.rmv").write_text(text, encoding="utf-8")
    return lower(check(str(folder / "abs.rmv"), use_environment=False))


def c_build(folder: Path, system: Any) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files(system).items():
        (folder / name).write_text(text)
    (folder / "harness.c").write_text(HARNESS)
    sources = [str(folder / "harness.c"), str(folder / "rmv_carla_abs.c")]
    subprocess.run([compiler() or "cc", *STRICT, "-O2", "-o", str(folder / "harness"), *sources,
                    "-lm"], check=True)  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    spec = lower(check(str(ROOT / "examples" / "carla" / "abs.rmv"), use_environment=False))
    system = system_of(spec)
    samples = drive(args.samples)
    python_times: list[float] = []
    records: list[dict] = []
    verdicts: list[dict] = []
    for _ in range(args.repeat):
        spent, records, verdicts = runtime_run(spec, samples)
        python_times.append(spent)
    with tempfile.TemporaryDirectory() as folder_name:
        folder = Path(folder_name)
        declared = system_of(declared_spec(folder / "declared"))
        assert [q.name for q in declared.flow.queries] == ["EderivativeVelocity"]
        c_build(folder / "given", system)
        c_build(folder / "fields", declared)
        data = instants(system, samples, records)
        only_fields = instants(declared, samples, [])
        c_times, field_times = [], []
        names = [p.name for p in system.properties]
        for _ in range(args.repeat):
            spent, got = c_run(folder / "given", data, names)
            c_times.append(spent)
            spent, got_fields = c_run(folder / "fields", only_fields, names)
            field_times.append(spent)
    expected = segments_by_property(verdicts)
    if got != expected or got_fields != expected:
        print("the C monitor and the runtime disagree", file=sys.stderr)
        return 1
    python, native, from_fields = min(python_times), min(c_times), min(field_times)
    result = {
        "samples": args.samples,
        "instants_given_to_c": len(data) // (9 + 8 * len(system.flow.sources)),
        "python_runtime_samples_per_s": args.samples / python,
        "c_from_values_samples_per_s": args.samples / native,
        "ratio": python / native,
        "c_from_fields_samples_per_s": args.samples / from_fields,
        "ratio_from_fields": python / from_fields,
        "c_from_fields_seconds": from_fields,
        "python_seconds": python,
        "c_seconds": native,
        "segments": sum(len(v) for v in expected.values()),
    }
    print(f"{args.samples} status messages at 100 Hz, abs.rmv "
          f"({result['segments']} verdict segments, equal)")  # fmt: skip
    print(f"  runtime (everything, from messages): {python:.2f} s, "
          f"{result['python_runtime_samples_per_s']:,.0f} samples/s")  # fmt: skip
    rate, ratio = result["c_from_values_samples_per_s"], result["ratio"]
    print(f"  C from values (events, transducer, properties): {native:.4f} s, "
          f"{rate:,.0f} samples/s ({ratio:.0f}x)")  # fmt: skip
    rate, ratio = result["c_from_fields_samples_per_s"], result["ratio_from_fields"]
    print(f"  C from the fields (its query too): {from_fields:.4f} s, "
          f"{rate:,.0f} samples/s ({ratio:.0f}x)")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
