"""Shared by the C target's tests and benchmarks: compile a build's replay driver
(once per batch), feed it samples, and produce the same samples and verdicts from
the Python runtime."""

from __future__ import annotations

import json
import shutil
import subprocess
from collections.abc import Iterable, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

from rmvdsl.runtime.rmtld3 import Monitor, merge
from rmvdsl.runtime.values import exact_text

STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
SANITIZERS = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-g", "-O1"]


def compiler() -> str | None:
    return shutil.which("gcc") or shutil.which("cc")


def write(files: dict[str, str], folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text, encoding="utf-8")


def compile_driver(
    folder: Path, sanitize: bool = False, optimize: str = "-O2", cc: str | None = None
) -> Path:
    """The replay driver of the build in `folder`, compiled with the strict flags
    (by `cc`, gcc unless named)."""
    (driver,) = folder.glob("rmv_*_replay.c")
    program = folder / f"{driver.stem}_{Path(cc or 'cc').name}"
    flags = [*STRICT, *(SANITIZERS if sanitize else [optimize])]
    sources = [str(driver), str(driver).replace("_replay.c", ".c"), "-lm"]
    done = subprocess.run([cc or compiler() or "cc", *flags, "-o", str(program), *sources],
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 0, done.stderr[-4000:]
    return program


def run_driver(
    program: Path, lines: Iterable[str], *args: str
) -> tuple[int, list[dict[str, Any]], str]:
    """Exit status, the records printed, and standard error."""
    done = subprocess.run([str(program), *args], input="".join(f"{line}\n" for line in lines),
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    records = [
        json.loads(line, parse_float=lambda s: Fraction(s)) for line in done.stdout.splitlines()
    ]
    return done.returncode, records, done.stderr


def segments_by_property(records: Sequence[dict[str, Any]]) -> dict[str, list[tuple]]:
    """Verdict records as merged segments per property (times as Fractions)."""
    found: dict[str, list[tuple]] = {}
    for r in records:
        if r.get("kind") != "verdict":
            continue
        segment = (Fraction(r["from"]), Fraction(r["to"]), r["bounds"][0] == "[",
                   r["bounds"][1] == "]", r["verdict"])  # fmt: skip
        found.setdefault(r["property"], []).append(segment)
    return {name: merge(segments) for name, segments in found.items()}


def sample_line(t: Fraction, props: Iterable[str], pulses: Iterable[str] = ()) -> str:
    """One sample as the driver reads it (t in seconds, exactly)."""
    record: dict[str, Any] = {"t": "@", "props": sorted(props)}
    if pulses:
        record["pulses"] = sorted(pulses)
    return json.dumps(record).replace('"@"', exact_text(Fraction(t)))


def end_line(t: Fraction) -> str:
    return f'{{"t": {exact_text(Fraction(t))}, "end": true}}'


def monitor_segments(
    formula: Any, samples: Sequence[tuple[Any, ...]], end: Fraction
) -> list[tuple]:
    """The Python monitor's merged verdict segments over samples (time, state) or
    (time, state, pulses), as rmv eval runs it."""
    monitor = Monitor(formula)
    for t, state, *pulses in samples:
        monitor.step(t, state, *pulses)
    monitor.end(end)
    return merge(monitor.verdicts())


def property_inputs(spec: Any, recordings: Sequence[Path]) -> tuple[list[str], list[str]]:
    """What the Python runtime's property monitors read while `rmv replay` runs the
    spec over recordings, as driver lines (initial states, then each instant's
    propositions and pulses, then the end), and the verdict records `rmv replay
    --format jsonl` prints."""
    from unittest import mock

    from rmvdsl.runtime import engine
    from rmvdsl.tools.replay import replay

    lines: list[str] = []
    truth: set[str] = set()
    seen: list[Any] = []

    class Logged(engine.PropertyMonitor):
        def __init__(self, prop: Any, start: int, initial: frozenset[str]) -> None:
            super().__init__(prop, start, initial)
            if not seen:
                truth.update(initial)
                lines.append(sample_line(Fraction(start, 10**9), truth))
            seen.append(self)

        def instant(self, time: int, changes: list[tuple[str, Any]]) -> None:
            if self is seen[0]:
                pulses = set()
                for name, value in changes:
                    if value is True:
                        truth.add(name)
                    elif name in truth:
                        if any(n == name and v is True for n, v in changes):
                            pulses.add(name)
                        truth.discard(name)
                lines.append(sample_line(Fraction(time, 10**9), truth, pulses))
            super().instant(time, changes)

        def end(self, time: int) -> None:
            if self is seen[0]:
                lines.append(end_line(Fraction(time, 10**9)))
            super().end(time)

    from rmvdsl.runtime.records import to_json

    with mock.patch.object(engine, "PropertyMonitor", Logged):
        records = list(replay(spec, recordings))
    return lines, [to_json(r) for r in records if r["kind"] == "verdict"]
