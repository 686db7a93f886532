"""How long everyday commands take to start and finish, as new processes, with the
methods of rmvdsl's dataclasses compiled once per machine (rmvdsl.util.compiled)
against compiling them in every process (the baseline: the same command, whose
`dataclasses` is given the plain `exec` before rmvdsl is imported).

Commands, each on the CARLA example (examples/carla):

- version: `rmv --version` (nothing of the checker imported);
- fmt:     `rmv fmt --check abs.rmv`;
- check:   `rmv check abs.rmv` after a one-line edit (the solver's answers cached,
           as after any earlier check: the stages import and run);
- build:   `rmv build --target c abs.rmv` (the spec stored by the check before);
- eval:    `rmv eval` of a formula over a trace of 1,000 samples.

Each pair runs `--repeat` times, the two in turn, in a cache folder of this run's
own (written once before anything is timed). Reported: each one's median CPU
seconds and the median of the pairs' ratios (the machine is shared: read the
ratios).

    python benchmarks/bench_start.py --json benchmarks/results/start.json
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import peak
from as_installed import byte_compile

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "carla"
# `rmv`, or `rmv` with dataclasses compiling in this process as Python does alone.
KEPT = "from rmvdsl.cli import entry; entry()"
COMPILED = "import builtins, dataclasses; dataclasses.exec = builtins.exec; " + KEPT
FORMULA = "always[<=5] (Braking -> eventually[<=2] Stopped)"


def commands(folder: Path) -> dict[str, tuple[list[str], bool]]:
    """Each command's arguments, and whether the spec is edited before each run."""
    spec = str(folder / "abs.rmv")
    trace = folder / "trace.jsonl"
    states = ("Braking", "Stopped", "Cruising")
    lines = [json.dumps({"t": t / 10, "state": states[t // 7 % 3]}) for t in range(1000)]
    trace.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return {
        "version": (["--version"], False),
        "fmt": (["fmt", "--check", spec], False),
        "check": (["check", spec], True),
        "build": (["build", "--target", "c", spec, "-o", str(folder / "built")], False),
        "eval": (["eval", "--formula", FORMULA, "--trace", str(trace)], False),
    }


def _cpu(script: str, arguments: list[str], env: dict[str, str]) -> float:
    usage = peak.run([sys.executable, "-c", script, *arguments], stdout=subprocess.DEVNULL,
                     env=env)  # fmt: skip
    if usage.returncode not in (0, 1):  # fmt --check: 1 when a file would change
        raise SystemExit(f"rmv {' '.join(arguments)} failed ({usage.returncode}): {usage.stderr}")
    return usage.cpu


def measure(repeat: int) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / "carla"
        shutil.copytree(EXAMPLE, folder, ignore=shutil.ignore_patterns("recordings"))
        env = {**os.environ, "RMV_CACHE_DIR": str(Path(scratch) / "cache")}
        results: dict[str, Any] = {}
        for name, (arguments, edited) in commands(folder).items():
            _cpu(KEPT, arguments, env)  # the kept code written, the answers cached
            kept, compiled, ratios = [], [], []
            for round_ in range(repeat):
                pair = []
                for script in (KEPT, COMPILED):
                    if edited:  # a new text each run: its stored output never read
                        with open(folder / "abs.rmv", "a", encoding="utf-8") as spec:
                            spec.write(f"// edit {round_} {len(pair)}\n")
                    pair.append(_cpu(script, arguments, env))
                kept.append(pair[0])
                compiled.append(pair[1])
                ratios.append(pair[0] / pair[1])
            results[name] = {
                "kept_cpu_s": statistics.median(kept),
                "compiled_cpu_s": statistics.median(compiled),
                "kept / compiled": statistics.median(ratios),
            }
            print(f"{name:<8} {results[name]['kept_cpu_s']:6.3f} s  "
                  f"{results[name]['compiled_cpu_s']:6.3f} s  "
                  f"{results[name]['kept / compiled']:5.2f}x", flush=True)  # fmt: skip
        return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args()
    byte_compile()  # as an install holds rmvdsl: compiled
    print(f"{'command':<8} {'kept':>8} {'compiled':>9} {'ratio':>6}  (CPU seconds, medians)")
    results = {"repeat": args.repeat, "commands": measure(args.repeat)}
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
