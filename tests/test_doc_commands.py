"""The commands the documentation shows are tests: every line of a fenced `sh` or
`console` block in README.md and docs/*.md that runs `rmv` is run here, against the
installed package, in a temporary copy of examples/, and its exit code and (where a
`console` block shows it) its output are checked.

How a document says what to expect, in an HTML comment on the line before a block:
- `<!-- exit: N -->`: every command of the block exits N (default 0);
- `<!-- not-run: why -->`: the block is not run (listed by a test, with its reason).
In a `console` block, `$ rmv ...` lines are commands and the lines after one are its
output (stdout, then stderr); a line `...` stands for any number of lines.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import EXAMPLES, FIXTURES, RMV, ROOT

DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(
    r"(?:<!--\s*(?P<marker>exit|not-run):\s*(?P<value>.*?)\s*-->\n)?"
    r"^```(?P<lang>sh|console)\n(?P<body>.*?)^```",
    re.MULTILINE | re.DOTALL,
)
# What a placeholder in the docs stands for here, and the files the docs name as a
# user's own (the thesis's YAML files, beside the examples in the working folder).
SUBSTITUTIONS = {
    " [--package NAME]": "",
    "[rostopicver.yaml] [rostopicintrusion.yaml]": "rostopicver.yaml rostopicintrusion.yaml",
}
USER_FILES = {
    "rostopicmon.yaml": FIXTURES / "thesis" / "rostopicmon.yaml",
    "rostopicver.yaml": FIXTURES / "thesis" / "rostopicver.yaml",
    "rostopicintrusion.yaml": FIXTURES / "thesis" / "rostopicintrusion.yaml",
}
# `pip install . && rmv ...` (README's first command): the install is what this runs against.
INSTALL = re.compile(r"^pip install [^&]*&& ")


@dataclass(frozen=True)
class Command:
    document: str
    line: int
    text: str
    exit: int
    output: tuple[str, ...] | None  # None: the document shows none
    skipped: str | None  # the not-run reason

    @property
    def id(self) -> str:
        return f"{self.document}:{self.line}"


def commands(documents: list[Path] = DOCUMENTS) -> list[Command]:
    found = []
    for path in documents:
        text = path.read_text(encoding="utf-8")
        for block in BLOCK.finditer(text):
            first = text.count("\n", 0, block.start("body")) + 1
            name = path.relative_to(ROOT).as_posix() if ROOT in path.parents else path.name
            found += _block_commands(name, first, block)
    return found


def _block_commands(document: str, first: int, block: re.Match[str]) -> list[Command]:
    marker, value = block.group("marker"), block.group("value")
    expected = int(value) if marker == "exit" else 0
    skipped = value if marker == "not-run" else None
    lines = block.group("body").splitlines()
    found: list[Command] = []
    console = block.group("lang") == "console"
    for i, line in enumerate(lines):
        line = INSTALL.sub("", line)
        if console:
            if not line.startswith("$ rmv "):
                continue
            output = []
            for after in lines[i + 1 :]:
                if after.startswith("$ "):
                    break
                output.append(after)
            found.append(Command(document, first + i, line[2:], expected,
                                 tuple(output) or None, skipped))  # fmt: skip
        elif line.startswith("rmv "):
            found.append(Command(document, first + i, line, expected, None, skipped))
    return found


ALL = commands()


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of examples/ and the user files the docs name; commands run here, in
    the documents' order (one may read what an earlier one wrote)."""
    folder = tmp_path_factory.mktemp("docs")
    shutil.copytree(EXAMPLES, folder / "examples")
    for name, source in USER_FILES.items():
        shutil.copy(source, folder / name)
    return folder


def substituted(text: str) -> str:
    for placeholder, value in SUBSTITUTIONS.items():
        text = text.replace(placeholder, value)
    return text


def matches(expected: tuple[str, ...], actual: list[str]) -> bool:
    """Do the lines match, `...` standing for any number of lines?"""
    if not expected:
        return not actual
    if expected[0] == "...":
        return any(matches(expected[1:], actual[i:]) for i in range(len(actual) + 1))
    return bool(actual) and expected[0] == actual[0] and matches(expected[1:], actual[1:])


@pytest.mark.parametrize("command", [c for c in ALL if c.skipped is None], ids=lambda c: c.id)
def test_a_documented_command_does_what_its_document_says(command: Command, workdir: Path):
    assert len(RMV) == 1, "the docs' commands need the `rmv` script: install the package"
    script = Path(RMV[0])
    environment = {**os.environ, "PATH": f"{script.parent}{os.pathsep}{os.environ['PATH']}",
                   "NO_COLOR": "1", "COLUMNS": "100"}  # fmt: skip
    run = subprocess.run(
        ["bash", "-c", substituted(command.text)], cwd=workdir, env=environment,
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    shown = (
        f"{command.id}: {command.text}\n"
        f"stdout:\n{run.stdout[-3000:]}\nstderr:\n{run.stderr[-3000:]}"
    )
    assert run.returncode == command.exit, shown
    if command.output is not None:
        actual = [
            line.rstrip()
            for line in (run.stdout + run.stderr).replace(str(workdir) + "/", "").splitlines()
        ]
        assert matches(tuple(line.rstrip() for line in command.output), actual), shown


def test_the_commands_not_run_are_listed_with_their_reasons():
    skipped = {c.id: (c.text, c.skipped) for c in ALL if c.skipped is not None}
    for where, (text, why) in skipped.items():
        assert why, f"{where}: `{text}` is marked not-run without a reason"
    print("\n".join(f"{w}: {t}  ({why})" for w, (t, why) in skipped.items()))


def test_every_command_of_rmv_is_shown_running_in_the_docs():
    from rmvdsl.commands.arguments import build_parser

    parser = build_parser()
    names = set(parser._subparsers._group_actions[0].choices)  # type: ignore[union-attr]
    shown = {c.text.split()[1] for c in ALL}
    assert names - shown == set()


def test_the_collector_finds_and_judges(tmp_path: Path):
    """The harness itself: markers, console output, `...`, placeholders."""
    page = tmp_path / "page.md"
    page.write_text(
        "<!-- exit: 1 -->\n```console\n$ rmv check a.rmv\nerror\n...\nend\n```\n\n"
        "<!-- not-run: needs a robot -->\n```sh\nrmv deploy x\n```\n"
        "```sh\npip install . && rmv fmt a.rmv\nls\n```\n```text\nrmv check b.rmv\n```\n",
        encoding="utf-8",
    )
    found = [(c.text, c.exit, c.output, c.skipped) for c in commands([page])]
    assert found == [
        ("rmv check a.rmv", 1, ("error", "...", "end"), None),
        ("rmv deploy x", 0, None, "needs a robot"),
        ("rmv fmt a.rmv", 0, None, None),
    ]
    assert matches(("a", "...", "d"), ["a", "b", "c", "d"])
    assert matches(("a", "...", "d"), ["a", "d"])
    assert not matches(("a", "...", "d"), ["a", "b"])
    assert not matches(("a",), ["a", "b"])
    assert substituted("rmv build x [--package NAME]") == "rmv build x"
