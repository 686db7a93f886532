"""`rmv lsp` as an editor feels it: a 2,000-line spec, edited a line at a time.

Starts the server as its own process and talks to it over stdio (pygls's client),
then measures in one run:

- change:     didChange -> the first publishDiagnostics of that version (the fast
              stages: load, names, types), p50/p95/p99/max over --edits edits, two
              keys in an event's line, then a property's, then a transducer's
              (each kind's p50/p95/p99 too);
- completion: a typist asking for completion after each key in an event's
              condition (` V` typed and erased in turn): p50/p95/p99/max;
- bare:       lark's bare parse of the same text in this process (the floor);
- in process: the same edits' fast stages in this process, from scratch and
              incremental (each declaration's names and types reused while its
              text and what it looked up are unchanged), p50: the server's share;
- memory:     the server's resident memory every 100 edits (goal: flat), and that
              of the processes it started (the solver process and its workers);
- pausing:    a typist pausing 0.5 s between keys (past the 0.3 s debounce) in a
              property's bound, so the solver stages of each text run while the
              next key's fast stages are asked for: p50/p95/p99/max;
- declaring:  a typist writing a new declaration on a line of its own, a key at a
              time, then erasing it: most of its texts have a syntax error (the
              keys no edit inside one declaration answers): p50/p95/p99/max.

Machines here are shared and noisy: the figures are printed beside the bare parse of
the same run. Goals: change p99 <= 50 ms, completion likewise, memory flat.

    python benchmarks/bench_lsp.py [--edits 1000] [--json benchmarks/results/lsp.json]
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from as_installed import byte_compile
from bench_check import write_messages
from lsprotocol import types
from pygls.lsp.client import LanguageClient

from rmvdsl.check import check
from rmvdsl.grammar.grammars import bare_spec_parser


def generate(scale: int = 1) -> str:
    """About 2,000 lines (times `scale`) in the shapes of bench_check.py's spec."""
    lines = ["system editing", "time unit s", 'messages "msg"', ""]
    topics, variables, events, machines = 100 * scale, 600 * scale, 200 * scale, 20 * scale
    lines += [f'topic T{t}: pkg_msgs/Msg{t % 50} = "/robot/sensor{t}"' for t in range(topics)]
    lines += [f"var V{v} = T{v % topics}.field{v % 7}.value" for v in range(variables)]
    for e in range(events):
        lines += [f"event E{e} = mean(V{e}) * 3.6", "    group by time(100ms)", "    fill previous"]
    lines += [f"event B{b} when V{events + b} > 0.8 and E{b} < 5" for b in range(events)]
    for d in range(machines):
        names = [f"S{d}_{s}" for s in range(10)]
        lines += [
            f"transducer D{d} {{",
            "    states " + ", ".join(names),
            f"    initial {names[0]}",
        ]
        lines += [f"    {names[s]} -> {names[(s + 1) % 10]} on B{d * 10 + s}" for s in range(10)]
        lines.append("}")
    lines += [f"alert A{a} {{ warn when V{2 * events + a} > 10 reset when V{2 * events + a} < 5 }}"
              for a in range(events)]  # fmt: skip
    lines += [f"property P{p}: S{p % machines}_0 -> eventually[<=10s] S{p % machines}_1 "
              "{ rate = 10Hz }" for p in range(100 * scale)]  # fmt: skip
    return "\n".join(lines) + "\n"


PAUSE = 0.5  # seconds between the pausing typist's keys: past the server's 0.3 s debounce
PAUSING_KEYS = 40
COMPLETIONS = 200  # requests of the completing typist, one after each key
DECLARED = "event Znew when V1 > 2"  # what the declaring typist writes, then erases


def percentile(values: list[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(len(ordered) * fraction))]


def resident_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status", encoding="ascii") as status:
        kb = next(int(line.split()[1]) for line in status if line.startswith("VmRSS"))
    return kb / 1024


def descendants(pid: int) -> list[int]:
    """The processes a process started, and theirs (the solver process, its workers)."""
    found = []
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/children", encoding="ascii") as listed:
            for child in map(int, listed.read().split()):
                found += [child, *descendants(child)]
    return found


async def run(edits: int, scale: int = 1) -> dict[str, Any]:
    folder = Path(tempfile.mkdtemp(prefix="rmv-bench-lsp-"))
    write_messages(str(folder))
    text = generate(scale)
    path = folder / "editing.rmv"
    path.write_text(text, encoding="utf-8")
    uri = path.as_uri()

    parser = bare_spec_parser()
    bare = min(_timed(lambda: parser.parse(text, start="start")) for _ in range(5))
    in_process = {
        "scratch_check_ms": _checks(str(path), text, incremental=False) * 1000,
        "incremental_check_ms": _checks(str(path), text, incremental=True) * 1000,
    }

    client = LanguageClient("bench-lsp", "1")
    # the server's solver answers go to a cache of this run's own, never the user's
    os.environ["RMV_CACHE_DIR"] = str(folder / "cache")
    await client.start_io(sys.executable, "-m", "rmvdsl.cli", "lsp")
    await client.initialize_async(types.InitializeParams(capabilities=types.ClientCapabilities()))
    client.initialized(types.InitializedParams())
    published: dict[int, float] = {}

    @client.feature(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    def on_diagnostics(params: types.PublishDiagnosticsParams) -> None:
        if params.version is not None:
            published.setdefault(params.version, time.perf_counter())

    shown: list[str] = []  # what the server told the user (an error would be here)

    @client.feature(types.WINDOW_SHOW_MESSAGE)
    def on_message(params: types.ShowMessageParams) -> None:
        shown.append(params.message)

    client.text_document_did_open(types.DidOpenTextDocumentParams(
        types.TextDocumentItem(uri=uri, language_id="rmv", version=1, text=text)))  # fmt: skip
    await _until(lambda: 1 in published)
    lines = text.split("\n")
    places = typing_places(lines)
    target = places["event"][0]
    changes: list[float] = []
    by_line: dict[str, list[float]] = {kind: [] for kind in places}
    series: list[float] = []  # the server's resident memory every 100 edits
    pid = client._server.pid  # type: ignore[union-attr]
    for version in range(2, edits + 2):
        # Typing and erasing in turn (as _typed): a digit inserted, then removed, so
        # that every later declaration moves by one character and back; two keys in
        # an event's line, then in a property's, then in a transducer's.
        kind = _kind_typed(version)
        line, column = places[kind]
        at = types.Position(line, column)
        if version % 2 == 0:
            edit = types.TextDocumentContentChangePartial(range=types.Range(at, at), text="7")
        else:
            after = types.Position(line, column + 1)
            edit = types.TextDocumentContentChangePartial(range=types.Range(at, after), text="")
        start = time.perf_counter()
        client.text_document_did_change(types.DidChangeTextDocumentParams(
            types.VersionedTextDocumentIdentifier(uri=uri, version=version), [edit]))  # fmt: skip
        await _until(lambda v=version: v in published)
        changes.append(published[version] - start)
        by_line[kind].append(changes[-1])
        if (version - 1) % 100 == 0:
            series.append(round(resident_mb(pid), 1))
    memory = {"after_100_mb": series[0], "after_all_mb": series[-1], "memory_mb": series}
    pausing = await _pausing_typist(client, uri, lines, edits + 2, published)
    # after the pausing typist, whose pauses let solver stages run
    memory["solver_processes_mb"] = round(sum(resident_mb(p) for p in descendants(pid)), 1)
    completions = await _completing_typist(client, uri, lines[target], target,
                                           edits + 2 + PAUSING_KEYS)  # fmt: skip
    below = next(i for i, line in enumerate(lines) if line.startswith("transducer"))
    later = edits + 2 + PAUSING_KEYS + COMPLETIONS
    declaring = await _declaring_typist(client, uri, below, later, published)
    await client.shutdown_async(None)
    client.exit(None)
    await client.stop()
    ms = 1000.0
    return {
        "lines": len(lines), "edits": edits, "bare_parse_ms": bare * ms,
        "change_p50_ms": percentile(changes, 0.5) * ms,
        "change_p95_ms": percentile(changes, 0.95) * ms,
        "completion_p50_ms": percentile(completions, 0.5) * ms,
        "completion_p95_ms": percentile(completions, 0.95) * ms,
        "completion_p99_ms": percentile(completions, 0.99) * ms,
        "completion_max_ms": max(completions) * ms, **memory, **in_process,
        "server_messages": shown[:5], "server_message_count": len(shown),
        "change_p99_ms": percentile(changes, 0.99) * ms, "change_max_ms": max(changes) * ms,
        "first_two_ms": [round(c * ms, 1) for c in changes[:2]],
        "change_by_line": {
            kind: {"edits": len(found), "p50_ms": percentile(found, 0.5) * ms,
                   "p95_ms": percentile(found, 0.95) * ms, "p99_ms": percentile(found, 0.99) * ms}
            for kind, found in by_line.items() if found
        },
        "pausing_keys": len(pausing), "pause_s": PAUSE,
        "pausing_p50_ms": percentile(pausing, 0.5) * ms,
        "pausing_p95_ms": percentile(pausing, 0.95) * ms,
        "pausing_p99_ms": percentile(pausing, 0.99) * ms, "pausing_max_ms": max(pausing) * ms,
        "declaring_keys": len(declaring),
        "declaring_p50_ms": percentile(declaring, 0.5) * ms,
        "declaring_p95_ms": percentile(declaring, 0.95) * ms,
        "declaring_p99_ms": percentile(declaring, 0.99) * ms,
        "declaring_max_ms": max(declaring) * ms,
    }  # fmt: skip


async def _declaring_typist(
    client: LanguageClient, uri: str, line: int, version: int, published: dict[int, float]
) -> list[float]:
    """A typist writing DECLARED on a new line before `line`, a key at a time, then
    erasing it a key at a time (and the line): each key's didChange -> its
    diagnostics."""
    start, below = types.Position(line, 0), types.Position(line + 1, 0)
    keys = [(types.Range(start, start), "\n")]
    keys += [(types.Range(types.Position(line, k), types.Position(line, k)), character)
             for k, character in enumerate(DECLARED)]  # fmt: skip
    keys += [(types.Range(types.Position(line, k), types.Position(line, k + 1)), "")
             for k in reversed(range(len(DECLARED)))]  # fmt: skip
    keys.append((types.Range(start, below), ""))
    times = []
    for key, (where, typed) in enumerate(keys):
        edit = types.TextDocumentContentChangePartial(range=where, text=typed)
        times.append(await _timed_key(client, uri, edit, version + key, published))
    return times


async def _timed_key(
    client: LanguageClient,
    uri: str,
    edit: types.TextDocumentContentChangePartial,
    version: int,
    published: dict[int, float],
) -> float:
    """One key sent: the time from its didChange to the diagnostics of its version."""
    document = types.VersionedTextDocumentIdentifier(uri=uri, version=version)
    begun = time.perf_counter()
    client.text_document_did_change(types.DidChangeTextDocumentParams(document, [edit]))
    await _until(lambda: version in published)
    return published[version] - begun


async def _pausing_typist(
    client: LanguageClient,
    uri: str,
    lines: list[str],
    version: int,
    published: dict[int, float],
) -> list[float]:
    """A typist who pauses past the debounce between keys, in a property's bound
    (`<=10s` <-> `<=100s`): each pause lets the solver stages start on the text
    before, so the next key's fast stages meet them running."""
    target = next(i for i, line in enumerate(lines) if line.startswith("property P0:"))
    column = lines[target].index("[<=") + 4
    at, after = types.Position(target, column), types.Position(target, column + 1)
    times = []
    for key in range(PAUSING_KEYS):
        await asyncio.sleep(PAUSE)
        typed = ("0", types.Range(at, at)) if key % 2 == 0 else ("", types.Range(at, after))
        edit = types.TextDocumentContentChangePartial(range=typed[1], text=typed[0])
        times.append(await _timed_key(client, uri, edit, version + key, published))
    return times


async def _completing_typist(
    client: LanguageClient, uri: str, line: str, target: int, version: int
) -> list[float]:
    """A typist asking for completion after each key, in an event's condition: ` V`
    typed at the end of the line and erased in turn (so the text the server scans
    changes with every request, as it does for a user); each request's round trip."""
    end = types.Position(target, len(line))
    typed = types.Position(target, len(line) + 2)
    times = []
    for key in range(COMPLETIONS):
        if key % 2 == 0:
            edit = types.TextDocumentContentChangePartial(range=types.Range(end, end), text=" V")
        else:
            edit = types.TextDocumentContentChangePartial(range=types.Range(end, typed), text="")
        document = types.VersionedTextDocumentIdentifier(uri=uri, version=version + key)
        client.text_document_did_change(types.DidChangeTextDocumentParams(document, [edit]))
        where = typed if key % 2 == 0 else end
        start = time.perf_counter()
        await client.text_document_completion_async(
            types.CompletionParams(types.TextDocumentIdentifier(uri), where)
        )
        times.append(time.perf_counter() - start)
    return times


def typing_places(lines: list[str]) -> dict[str, tuple[int, int]]:
    """Where the fast typist types, by the kind of line (0-based line and column): in
    an event's condition (`V200 > 0.8` becomes `V200 > 07.8`), in a property's bound
    (`[<=10s]`, `[<=170s]`) and at the end of a transition's event (`on B07`, a name
    not declared)."""
    event = next(i for i, line in enumerate(lines) if line.startswith("event B0 when"))
    prop = next(i for i, line in enumerate(lines) if line.startswith("property P0:"))
    transition = next(i for i, line in enumerate(lines) if line.startswith("    S0_0 -> "))
    return {
        "event": (event, 22),
        "property": (prop, lines[prop].index("[<=") + 4),
        "transducer": (transition, len(lines[transition])),
    }


def _kind_typed(version: int) -> str:
    """The kind of line the fast typist's edit `version` is in: two keys each."""
    return ("event", "property", "transducer")[(version - 2) // 2 % 3]


def _typed(text: str, version: int, line: int, column: int = 22) -> str:
    """A digit typed at `column` of `line` (even versions), erased (odd ones)."""
    lines = text.split("\n")
    if version % 2 == 0:
        lines[line] = lines[line][:column] + "7" + lines[line][column:]
    return "\n".join(lines)


def _checks(path: str, text: str, incremental: bool, edits: int = 60) -> float:
    """The p50 of the fast stages of `rmv check` over the fast typist's edits, here."""
    places = typing_places(text.split("\n"))
    check(path, text, solver=False, incremental=incremental)
    gc.collect()
    gc.freeze()  # as the server does after a document's first check
    times = []
    for version in range(2, edits + 2):
        edited = _typed(text, version, *places[_kind_typed(version)])
        times.append(_timed(lambda t=edited: check(path, t, solver=False, incremental=incremental)))
    return percentile(times, 0.5)


def _timed(action: Any) -> float:
    start = time.perf_counter()
    action()
    return time.perf_counter() - start


async def _until(condition: Any, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise SystemExit("the server did not answer in time")
        await asyncio.sleep(0.001)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--edits", type=int, default=1000)
    parser.add_argument("--scale", type=int, default=1,
                        help="the spec's size in 2,085-line units (10: 20,805 lines)")  # fmt: skip
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    byte_compile()  # as an install holds rmvdsl: compiled
    figures = asyncio.run(run(args.edits, args.scale))
    print(f"{figures['lines']:,} lines, {figures['edits']:,} edits; bare parse "
          f"{figures['bare_parse_ms']:.1f} ms")  # fmt: skip
    print(f"  fast stages in process, p50: {figures['scratch_check_ms']:.1f} ms from scratch, "
          f"{figures['incremental_check_ms']:.1f} ms incremental")  # fmt: skip
    print(f"  didChange -> diagnostics p50 / p95: {figures['change_p50_ms']:.1f} / "
          f"{figures['change_p95_ms']:.1f} ms (goal p95 <= 50 ms)")  # fmt: skip
    print(f"  didChange p99 / max: {figures['change_p99_ms']:.1f} / {figures['change_max_ms']:.1f}"
          f" ms; the first two keys after open: {figures['first_two_ms']} ms")  # fmt: skip
    print("  by the line typed in, p50 / p99: " + ", ".join(
        f"{kind} {found['p50_ms']:.1f} / {found['p99_ms']:.1f} ms"
        for kind, found in figures["change_by_line"].items()))  # fmt: skip
    print(f"  a typist pausing {figures['pause_s']} s ({figures['pausing_keys']} keys in a "
          f"property's bound), didChange -> diagnostics p50 / p95 / p99 / max: "
          f"{figures['pausing_p50_ms']:.1f} / {figures['pausing_p95_ms']:.1f} / "
          f"{figures['pausing_p99_ms']:.1f} / {figures['pausing_max_ms']:.1f} ms")  # fmt: skip
    print(f"  a typist writing `{DECLARED}` on a line of its own and erasing it "
          f"({figures['declaring_keys']} keys), didChange -> diagnostics p50 / p95 / p99 / max: "
          f"{figures['declaring_p50_ms']:.1f} / {figures['declaring_p95_ms']:.1f} / "
          f"{figures['declaring_p99_ms']:.1f} / {figures['declaring_max_ms']:.1f} ms")  # fmt: skip
    if figures["server_message_count"]:
        print(f"  the server showed {figures['server_message_count']} messages, the first: "
              f"{figures['server_messages']}")  # fmt: skip
    completion = [figures[f"completion_{p}_ms"] for p in ("p50", "p95", "p99", "max")]
    print(f"  completion after each key ({COMPLETIONS}), p50 / p95 / p99 / max: "
          + " / ".join(f"{c:.1f}" for c in completion) + " ms")  # fmt: skip
    print(f"  server memory after 100 edits {figures['after_100_mb']:.0f} MB, after all "
          f"{figures['after_all_mb']:.0f} MB (every 100: {figures['memory_mb']}); its solver "
          f"process and workers {figures['solver_processes_mb']:.0f} MB")  # fmt: skip
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
