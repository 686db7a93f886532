"""Documentation stays in step with the code."""

from __future__ import annotations

import re
import shutil

from conftest import ROOT

from rmvdsl.lang.codes import CODES, diagnostics_markdown


def test_diagnostics_page_is_generated_from_the_registry():
    assert (ROOT / "docs" / "diagnostics.md").read_text(encoding="utf-8") == diagnostics_markdown()


def test_every_code_used_in_the_source_is_registered():
    used = set()
    for path in (ROOT / "rmvdsl").rglob("*.py"):
        used |= set(re.findall(r'"(RMV\d{3})"', path.read_text(encoding="utf-8")))
    assert used - set(CODES) == set()
    assert set(CODES) - used == set(), "registered codes that nothing reports"


def test_language_reference_covers_every_declaration():
    text = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    for keyword in (
        "system",
        "import",
        "time unit",
        "database",
        "retention",
        "downsample",
        "topic",
        "qos",
        "var",
        "event",
        "where",
        "group by",
        "fill",
        "order",
        "limit",
        "resample",
        "range",
        "alert",
        "reset when",
        "action",
        "transducer",
        "states",
        "initial",
        "final",
        "complete",
        "emit",
        "property",
        "latex",
        "until",
        "since",
        "eventually",
        "always",
        "once",
        "historically",
        "duration",
        "whitelist",
        "node",
        "intrusion",
    ):
        assert f"`{keyword}" in text, keyword


def test_language_reference_examples_parse():
    from rmvdsl.grammar.parser import parse_source
    from rmvdsl.lang.source import SourceFile

    text = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```rmv\n(.*?)```", text, re.DOTALL)
    assert len(blocks) >= 15
    for block in blocks:
        parsed = parse_source(SourceFile("doc.rmv", block))
        assert [d for d in parsed.diagnostics if d.is_error] == [], block


def test_readme_commands_exist():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "rmv check examples/carla/abs.rmv" in readme
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    test_command = re.search(r"Run the tests \(what CI runs\):\n\n```sh\n(.*?)\n```", readme)
    assert test_command, "README states the test command in a ```sh block"
    wanted = "bash tests/install-wheel.sh && . .venv-installed/bin/activate && pytest"
    assert test_command.group(1) == wanted
    assert ci.rstrip().endswith(test_command.group(1)), "CI runs README's test command, last"


def test_readme_tour_checks_clean_and_its_mistake_reads_as_shown(rmv, tmp_path):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    tour = re.search(r"```rmv\n(.*?)```", readme, re.DOTALL).group(1)
    shown = re.search(r"```text\n(warning\[RMV203\].*?)```", readme, re.DOTALL).group(1)
    shutil.copytree(ROOT / "examples" / "carla" / "msg", tmp_path / "msg")
    spec = tmp_path / "spec.rmv"
    spec.write_text(tour, encoding="utf-8")
    assert rmv("check", "--strict", str(spec)).code == 0
    spec.write_text(tour.replace("when BrakePedal", "when BrakePedl"), encoding="utf-8")
    import os

    os.chdir(tmp_path)
    result = rmv("check", "--no-color", "spec.rmv")
    assert result.code == 1
    assert result.out == shown


def test_language_reference_mentions_every_keyword_of_the_grammar():
    from rmvdsl.grammar.grammars import keywords

    text = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    missing = sorted(k for k in keywords() if not re.search(rf"\b{k}\b", text))
    assert missing == []


def test_documented_figures_are_the_benchmarks_json():
    """Every figures block in README.md and docs/ is what benchmarks/figures.py
    renders from the committed JSON: a document cannot drift from its figures."""
    import sys

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import figures

    used = set()
    for path in figures.documents():
        text = path.read_text(encoding="utf-8")
        used.update(m.group("name") for m in figures.BLOCK.finditer(text))
        assert figures.refreshed(text) == text, f"{path}: run python benchmarks/figures.py"
    assert used == set(figures.BLOCKS), set(figures.BLOCKS) - used


def test_the_architecture_page_names_every_package_and_module():
    """docs/architecture.md says what lives where: a new folder or top-level module
    that it does not name fails here."""
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    package = ROOT / "rmvdsl"
    folders = [p.name + "/" for p in package.iterdir() if (p / "__init__.py").exists()]
    modules = [p.name for p in package.glob("*.py") if p.name != "__init__.py"]
    missing = [name for name in (*folders, *modules) if f"`{name}" not in page]
    assert missing == []
