"""The figures in the documentation, rendered from the benchmarks' JSON.

A benchmark run with `--json benchmarks/results/NAME.json` leaves its figures there;
a document shows them between two markers:

    <!-- figures NAME-TABLE -->
    ... (written by this script) ...
    <!-- /figures -->

`python benchmarks/figures.py` rewrites every such block in README.md and docs/;
`--check` only says which block differs (tests/test_docs.py runs it), so a document
cannot drift from the figures it quotes.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
BLOCK = re.compile(r"(<!-- figures (?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /figures -->)", re.S)


def _count(value: float | None) -> str:
    return "-" if value is None else f"{value:,.0f}"


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def monitor_per_sample(data: dict[str, Any]) -> str:
    section = data["per_sample"]
    tools = ("rmvdsl", "rtamt", "reelay", "hand loop")
    rows = [
        [name, *(_count(row.get(tool)) for tool in tools), f"{row['violations']:,}"]
        for name, row in section["rows"].items()
    ]
    note = (
        f"{section['samples']:,} samples ({section['changes']:,} state changes), "
        f"samples per second, best of {data['repeat']}:\n\n"
    )
    header = ["formula", "rmvdsl", "rtamt", "reelay", "hand loop", "false samples (all agree)"]
    return note + _table(header, rows)


def monitor_per_change(data: dict[str, Any]) -> str:
    section = data["per_change"]
    rows = []
    for name, row in section["rows"].items():
        ratio = f"{row['rmvdsl'] / row['reelay']:.2f}x" if row.get("reelay") else "-"
        tools = (_count(row.get(tool)) for tool in ("rmvdsl", "reelay", "rtamt"))
        rows.append([name, *tools, ratio, f"{row['false segments']:,}", f"{row['memory']}"])
    note = (
        f"The {section['change_points']:,} change points of {section['samples']:,} samples, "
        f"change points per second, best of {data['repeat']}:\n\n"
    )
    header = ["formula", "rmvdsl", "reelay (dense)", "rtamt (dense)", "rmvdsl / reelay",
              "false segments (all agree)", "breakpoints held"]  # fmt: skip
    return note + _table(header, rows)


def eval_end_to_end(data: dict[str, Any]) -> str:
    names = ("rmv eval", "rmv eval at 0", "json.loads per line", "csv.reader per row",
             "msgspec per chunk", "orjson per line", "whole trace in memory")  # fmt: skip
    ratio = "rmv eval / the standard library's reader"
    rows = []
    for key, row in data["rows"].items():
        count, shape = key.split()
        cells = [f"{int(count):,}", shape, f"{row['bytes'] / 1e6:.1f} MB"]
        for name in names:
            found = row.get(name)
            cells.append(f"{_count(found['samples_per_s'])} ({found['peak_mb']:.0f} MB)"
                         if found else "-")  # fmt: skip
        rows.append([*cells, f"{row[ratio]:.2f}"])
    header = ["samples", "shape", "file", *(f"{name} /s (peak)" for name in names),
              f"{ratio} (json.loads or csv.reader)"]  # fmt: skip
    return f"Samples per second end to end, best of {data['repeat']}:\n\n" + _table(header, rows)


def lsp_latency(data: dict[str, Any]) -> str:
    rows = [
        ["lark's bare parse of the text, in the benchmark's process",
         f"{data['bare_parse_ms']:.0f} ms"],
        ["the fast stages of one edit in that process, p50: from scratch / incremental",
         f"{data['scratch_check_ms']:.0f} / {data['incremental_check_ms']:.0f} ms"],
        [f"didChange -> first diagnostics of that version, p50 / p95 ({data['edits']} edits)",
         f"{data['change_p50_ms']:.0f} / {data['change_p95_ms']:.0f} ms"],
        ["the same, p99 / max; the first two keys after open",
         f"{data['change_p99_ms']:.0f} / {data['change_max_ms']:.0f} ms; "
         + " and ".join(f"{ms:.0f}" for ms in data["first_two_ms"]) + " ms"],
        ["the same by the line typed in, p50 / p99",
         "; ".join(f"{kind} {found['p50_ms']:.0f} / {found['p99_ms']:.0f} ms"
                   for kind, found in data.get("change_by_line", {}).items()) or "-"],
        [f"a typist pausing {data['pause_s']} s between keys (past the debounce), "
         f"{data['pausing_keys']} keys in a property's bound: p50 / p95 / p99 / max",
         f"{data['pausing_p50_ms']:.0f} / {data['pausing_p95_ms']:.0f} / "
         f"{data['pausing_p99_ms']:.0f} / {data['pausing_max_ms']:.0f} ms"],
        [f"a typist writing a declaration on a new line and erasing it, "
         f"{data['declaring_keys']} keys (most of its texts have a syntax error): "
         "p50 / p95 / p99 / max",
         f"{data['declaring_p50_ms']:.0f} / {data['declaring_p95_ms']:.0f} / "
         f"{data['declaring_p99_ms']:.0f} / {data['declaring_max_ms']:.0f} ms"
         if "declaring_keys" in data else "-"],
        ["messages the server showed the user (an error would be one)",
         str(data["server_message_count"])],
        ["completion after each key in an event's condition: p50 / p95 / p99 / max",
         f"{data['completion_p50_ms']:.0f} / {data['completion_p95_ms']:.0f} / "
         f"{data['completion_p99_ms']:.0f} / {data['completion_max_ms']:.0f} ms"],
        [f"the server's memory after 100 edits / after {data['edits']}",
         f"{data['after_100_mb']:.0f} / {data['after_all_mb']:.0f} MB"],
        ["the server's memory every 100 edits, lowest / highest",
         f"{min(data['memory_mb']):.0f} / {max(data['memory_mb']):.0f} MB"],
        ["the solver process and its workers, after the pausing typist",
         f"{data['solver_processes_mb']:.0f} MB" if "solver_processes_mb" in data else "-"],
    ]  # fmt: skip
    return _table(["measure", "figure"], rows)


def ros2_node(data: dict[str, Any]) -> str:
    rate, latency = data["rate"], data["latency"]
    bare, node = latency["bare"], latency["monitor"]
    rows = [
        [f"rate, {rate['bare']['messages']:,} messages at once: msg/s of wall time",
         _count(rate["bare"]["per_second"]), _count(rate["monitor"]["per_second"])],
        ["rate: msg/s per CPU second of the reader (its ceiling on a core of its own)",
         _count(rate["bare"]["per_cpu_second"]),
         f"{_count(rate['monitor']['per_cpu_second'])} ({rate['share']:.0%}; goal >= 50%)"],
        [f"latency at 1 kHz, {bare['answers']:,} messages, sender to answer: p50 / p99 / max",
         f"{bare['p50_ms']:.2f} / {bare['p99_ms']:.2f} / {bare['max_ms']:.1f} ms (echo)",
         f"{node['p50_ms']:.2f} / {node['p99_ms']:.1f} / {node['max_ms']:.1f} ms (verdict)"],
        ["latency inside the node, a message's arrival (rmw's `received_timestamp`) to its "
         "verdict published: p50 / p99", "",
         f"{node['node_p50_ms']:.2f} / {node['node_p99_ms']:.2f} ms"],
    ]  # fmt: skip
    return _table(["measure", "bare rclpy subscriber", "monitor node"], rows)


def ros2_workload(data: dict[str, Any]) -> str:
    rows = []
    for rate, row in data["workload"].items():
        read = row["messages_to_read"]
        rows.append([f"{rate}, {row['seconds']:.0f} s", f"{row['messages_sent']:,}",
                     f"{row['cpu_share']:.1%}", f"{row['peak_rss_mb']:.0f} MB",
                     f"{row['messages_lost']:,} of {read:,}"])  # fmt: skip
    header = ["rate", "messages", "CPU (one core)", "peak RSS",
              "lost by the node's readers (depth 10), counted"]  # fmt: skip
    return _table(header, rows)


STORAGE_NAMES = {"bag": "ROS 1 .bag", "db3": "ROS 2 .db3", "mcap": "ROS 2 .mcap"}


def replay_speed(data: dict[str, Any]) -> str:
    rows = []
    for storage, recordings in data.items():
        for label, row in recordings.items():
            rows.append([STORAGE_NAMES.get(storage, storage), label, f"{row['messages']:,}",
                         _count(row["bare_per_second"]), _count(row["replay_per_second"]),
                         f"{row['replay_fraction_of_bare']:.0%}",
                         f"{row['replay_cpu_fraction_of_bare']:.0%}",
                         f"{row['bare_peak_rss'] / 2**20:.0f} MB",
                         f"{row['replay_peak_rss'] / 2**20:.0f} MB",
                         f"{row['replay_rss_beyond_bare'] / 2**20:.0f} MB"])  # fmt: skip
    header = ["storage", "recording", "messages", "bare read msg/s", "replay msg/s",
              "replay / bare", "bare CPU / replay CPU", "bare peak RSS", "replay peak RSS",
              "replay beyond bare"]  # fmt: skip
    return _table(header, rows)


def replay_start(data: dict[str, Any]) -> str:
    rows = []
    for storage, row in data.items():
        if storage in ("repeat", "build"):
            continue
        rows.append([STORAGE_NAMES.get(storage, storage), f"{row['bare_wall']:.2f} s",
                     f"{row['checked_wall']:.2f} s ({row['checked_over_bare']:.1f}x)",
                     f"{row['stored_wall']:.2f} s ({row['stored_over_bare']:.1f}x)",
                     f"{row['stored_over_checked']:.0%}"])  # fmt: skip
    header = ["storage", "bare read", "replay checking the spec (/ bare)",
              "replay of the stored spec (/ bare)", "stored / checking"]  # fmt: skip
    return _table(header, rows)


def build_start(data: dict[str, Any]) -> str:
    row = data["build"]
    return (
        f"medians of {data['repeat']} interleaved rounds (`python "
        "benchmarks/bench_replay_start.py`), each a new process: checking the spec "
        f"{row['checked_wall']:.2f} s ({row['checked_cpu']:.2f} s of CPU), from the stored "
        f"spec {row['stored_wall']:.2f} s ({row['stored_cpu']:.2f} s), "
        f"{row['stored_over_checked']:.0%} of the time.\n"
    )


def command_start(data: dict[str, Any]) -> str:
    words = {"version": "`rmv --version`", "fmt": "`rmv fmt --check abs.rmv`",
             "check": "`rmv check abs.rmv` after an edit", "build": "`rmv build --target c`",
             "eval": "`rmv eval`, 1,000 samples"}  # fmt: skip
    rows = [
        [words.get(name, name), f"{row['kept_cpu_s']:.3f} s", f"{row['compiled_cpu_s']:.3f} s",
         f"{row['kept / compiled']:.2f}x"]
        for name, row in data["commands"].items()
    ]  # fmt: skip
    header = ["command (CARLA example)", "code kept", "compiled in the process", "kept / compiled"]
    return _table(header, rows)


def replay_decoding(data: dict[str, Any]) -> str:
    rows = [
        [STORAGE_NAMES.get(storage, storage), msgtype, f"{row['messages']:,}",
         f"{row['full_us']:.1f}", f"{row['partial_us']:.1f}", f"{row['partial_of_full']:.2f}"]
        for storage, types in data.items()
        for msgtype, row in types.items()
    ]  # fmt: skip
    header = ["storage", "message type", "messages", "full decoder µs", "fields read µs",
              "ratio"]  # fmt: skip
    return _table(header, rows)


def check_scaling(data: dict[str, Any]) -> str:
    rows = []
    for scale, row in data.items():
        alone = f"{row['alone']:.1f} s" if row.get("alone") else ""
        rows.append([f"scale {scale} ({500 * int(scale):,} properties)", f"{row['lines']:,}",
                     f"{row['bare']:.2f} s",
                     f"{row['check']:.2f} s ({row['check'] / row['bare']:.1f}x)",
                     f"{row['first']:.1f} s", alone])  # fmt: skip
    scales = sorted(data, key=int)
    if len(scales) > 1 and scales[0] == "1":
        for scale in scales[1:]:
            big, small = data[scale], data["1"]
            rows.append([f"{scale}x / 1x", "", "", f"{big['check'] / small['check']:.1f}",
                         f"{big['first'] / small['first']:.1f}", ""])  # fmt: skip
    header = ["spec", "lines", "bare parse", "cached check", "first check, workers",
              "first check, no worker"]  # fmt: skip
    return _table(header, rows)


def sat_families(data: dict[str, Any]) -> str:
    rows, shown = [], None
    for row in data["families"]:
        base = row["unrolled_seconds"]
        baseline = f"{base:.3f} s" if base else "over the limit"
        formula = "" if row["formula"] == shown else f"`{row['formula']}`".replace("|", "\\|")
        shown = row["formula"]
        cells = [formula, str(row["b"]), row["sat"], row["valid"], f"{row['seconds']:.3f} s"]
        rows.append([*cells, baseline])
    header = ["formula (B = b)", "b", "sat", "valid", "rmvdsl", "unrolled baseline (same answers)"]
    return _table(header, rows)


def sat_requirements(data: dict[str, Any]) -> str:
    rows = [
        [str(row["requirements"]), row["together"], f"{row['consistency_seconds']:.2f} s",
         f"{row['check_seconds']:.2f} s", ", ".join(row["codes"]) or "none"]
        for row in data["sets"]
    ]  # fmt: skip
    header = ["requirements", "together", "consistency", "rmv check", "diagnostics"]
    return _table(header, rows)


def timescales(data: dict[str, Any]) -> str:
    rows = []
    for row in data["results"]:
        ours, discrete, dense = row["rmv eval"], row["reelay discrete"], row["reelay dense"]
        rows.append([
            row["pattern"], f"{row['rows']:,}", f"{ours['cpu_s']:.2f}",
            f"{discrete['cpu_s']:.2f}", f"{dense['cpu_s']:.2f}",
            f"{row['rmv eval / reelay discrete']:.2f}x", f"{row['rmv eval / reelay dense']:.2f}x",
            f"{ours['peak_mb']:.0f} / {discrete['peak_mb']:.0f} / {dense['peak_mb']:.0f}",
            f"{row['false rows']} ({row['rows false in dense time']})",
        ])  # fmt: skip
    note = (
        f"Bounds {data['lower']} and {data['upper']}; CPU seconds of each whole process "
        f"(user and system), medians of {data['repeat']} rounds (each tool once a round, "
        "in turn); the ratios are the medians of each round's:\n\n"
    )
    header = ["pattern", "rows", "rmv eval", "reelay discrete", "reelay dense",
              "/ discrete", "/ dense", "peak MB (ours / discrete / dense)",
              "false rows (in dense time)"]  # fmt: skip
    return note + _table(header, rows)


# block name -> (results file, renderer)
BLOCKS: dict[str, tuple[str, Callable[[dict[str, Any]], str]]] = {
    "monitor-per-sample": ("monitor.json", monitor_per_sample),
    "monitor-per-change": ("monitor.json", monitor_per_change),
    "eval-end-to-end": ("eval.json", eval_end_to_end),
    "lsp-latency": ("lsp.json", lsp_latency),
    "lsp-latency-20k": ("lsp_20k.json", lsp_latency),
    "ros2-node": ("ros2.json", ros2_node),
    "ros2-workload": ("ros2.json", ros2_workload),
    "replay-speed": ("replay.json", replay_speed),
    "replay-decoding": ("decoding.json", replay_decoding),
    "replay-start": ("replay_start.json", replay_start),
    "build-start": ("replay_start.json", build_start),
    "check-scaling": ("check.json", check_scaling),
    "sat-families": ("sat.json", sat_families),
    "sat-requirements": ("sat.json", sat_requirements),
    "timescales": ("timescales.json", timescales),
    "command-start": ("start.json", command_start),
}


def render(name: str) -> str:
    if name not in BLOCKS:
        raise SystemExit(f"unknown figures block `{name}`: known are {', '.join(BLOCKS)}")
    file, renderer = BLOCKS[name]
    data = json.loads((RESULTS / file).read_text(encoding="utf-8"))
    note = f"<!-- from benchmarks/results/{file}: python benchmarks/figures.py -->\n"
    return note + renderer(data)


def refreshed(text: str) -> str:
    return BLOCK.sub(lambda m: m.group(1) + render(m.group("name")) + m.group(4), text)


def documents() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 on drift")
    args = parser.parse_args()
    stale = []
    for path in documents():
        text = path.read_text(encoding="utf-8")
        new = refreshed(text)
        if new != text:
            stale.append(path.relative_to(ROOT))
            if not args.check:
                path.write_text(new, encoding="utf-8")
    verb = "differ from the benchmarks' JSON" if args.check else "rewritten"
    for path in stale:
        print(f"{path}: figures {verb}")
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
