"""Checking from several threads at once (the language server checks on workers)."""

from __future__ import annotations

import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from conftest import EXAMPLES

from rmvdsl.check import check
from rmvdsl.grammar import ast
from rmvdsl.grammar.parser import parse_source
from rmvdsl.lang.source import SourceFile


def _paths_in(spec: ast.Spec) -> set[str]:
    return {node.span.path for node in ast.walk(spec) if node.span.path != "<none>"}


def test_parsing_in_threads_keeps_each_parse_to_its_own_file(tmp_path: Path):
    text = (EXAMPLES / "carla" / "abs.rmv").read_text(encoding="utf-8")
    broken = text.replace("event HardBrake when", "event HardBrake when when", 1)
    sources = [SourceFile(f"spec{i}.rmv", broken if i % 2 else text) for i in range(8)]
    alone = {s.path: parse_source(s) for s in sources}

    def parse(source: SourceFile) -> bool:
        parsed = parse_source(source)
        paths = _paths_in(parsed.spec) | {d.span.path for d in parsed.diagnostics}
        return paths == {source.path} and parsed.diagnostics == alone[source.path].diagnostics

    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(parse, sources * 8))
    assert all(results), f"{results.count(False)} of {len(results)} parses saw another's state"


def test_checking_in_threads_is_safe_and_gives_the_same_answers(tmp_path: Path):
    for name in ("abs.rmv",):
        shutil.copy(EXAMPLES / "carla" / name, tmp_path / name)
    shutil.copytree(EXAMPLES / "carla" / "msg", tmp_path / "msg")
    analysis = EXAMPLES / "errors" / "analysis.rmv"
    targets = [str(tmp_path / "abs.rmv"), str(analysis)] * 3
    expected = {t: [d.code for d in check(t).diagnostics] for t in set(targets)}
    with ThreadPoolExecutor(max_workers=6) as pool:
        found = list(pool.map(lambda t: (t, [d.code for d in check(t).diagnostics]), targets))
    for target, codes in found:
        assert codes == expected[target], target


def test_a_parser_asked_for_by_threads_at_once_is_built_once():
    """The editor's event loop and its lanes ask for the same tables at the same
    moment: one builds them, the others wait and get the same parser."""
    import threading
    import time

    from rmvdsl.grammar.grammars import built_once

    builds: list[str] = []

    @built_once
    def tables(which: str) -> object:
        builds.append(which)
        time.sleep(0.2)  # long enough for every thread to ask meanwhile
        return object()

    start = threading.Barrier(6)

    def ask(which: str) -> object:
        start.wait()
        return tables(which)

    with ThreadPoolExecutor(max_workers=6) as pool:
        got = list(pool.map(ask, ["spec"] * 4 + ["latex"] * 2))
    assert sorted(builds) == ["latex", "spec"]
    assert len({id(g) for g in got[:4]}) == 1 and len({id(g) for g in got[4:]}) == 1
