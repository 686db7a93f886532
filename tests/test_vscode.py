"""The VS Code extension (editor/vscode/): its TextMate grammar judged by
vscode-tmgrammar-test's scope assertions, and a .vsix built by vsce, both from the
npm registry (`npm ci` with the committed package-lock.json)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from conftest import ROOT

from rmvdsl.lang.builtins import FUNCTIONS

EXTENSION = ROOT / "editor" / "vscode"
GRAMMAR = EXTENSION / "syntaxes" / "rmv.tmLanguage.json"


def _npm(*args: str, cwd: Path = EXTENSION, timeout: float = 600) -> subprocess.CompletedProcess:
    npm = shutil.which("npm")
    assert npm, "the extension's tests need Node.js and npm (.ci/run has them)"
    return subprocess.run([npm, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def installed() -> Path:
    """The extension's packages from the npm registry, as the lock file pins them."""
    if not (EXTENSION / "node_modules" / ".package-lock.json").exists():
        done = _npm("ci", "--no-audit", "--no-fund")
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return EXTENSION


def _tool(name: str, *args: str, cwd: Path = EXTENSION) -> subprocess.CompletedProcess:
    """One of the extension's npm tools, as `npm ci` installed it."""
    binary = EXTENSION / "node_modules" / ".bin" / name
    return subprocess.run(
        [str(binary), *args], cwd=cwd, capture_output=True, text=True, timeout=600
    )


def _grammar_test(folder: Path, pattern: str) -> subprocess.CompletedProcess:
    return _tool("vscode-tmgrammar-test", "-g", str(GRAMMAR), pattern, cwd=folder)


def test_highlighting_meets_its_scope_assertions(installed, tmp_path):
    run = _grammar_test(installed, "test/**/*.rmv")
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert run.stdout.count("run successfuly") == len(list((installed / "test").glob("*.rmv")))
    # the assertions can fail: a wrong scope is found
    wrong = (installed / "test" / "declarations.rmv").read_text(encoding="utf-8")
    (tmp_path / "wrong.rmv").write_text(
        wrong.replace("support.function.builtin.rmv", "keyword.other.clause.rmv", 1),
        encoding="utf-8",
    )
    run = _grammar_test(tmp_path, "wrong.rmv")
    assert run.returncode != 0 and "missing required scopes" in run.stdout


def test_the_grammar_knows_every_function_and_keyword():
    text = GRAMMAR.read_text(encoding="utf-8")
    grammar = json.loads(text)
    functions = grammar["repository"]["functions"]["patterns"][0]["match"]
    assert set(FUNCTIONS) <= set(re.findall(r"[a-z_0-9]+", functions))
    lark = "".join(
        p.read_text(encoding="utf-8") for p in (ROOT / "rmvdsl" / "grammar").glob("*.lark")
    )
    keywords = set(re.findall(r'"([a-z_]{2,})"', lark)) - {"true", "false", "none"}
    words = set(re.findall(r"[a-z_]+", json.dumps(grammar["repository"]["keywords"])))
    assert keywords - words == set()


def test_vsce_packages_the_extension(installed, tmp_path):
    vsix = tmp_path / "rmvdsl.vsix"
    run = _tool("vsce", "package", "--allow-missing-repository", "-o", str(vsix))
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    with zipfile.ZipFile(vsix) as archive:
        names = set(archive.namelist())
        manifest = json.loads(archive.read("extension/package.json"))
    for wanted in ("extension/extension.js", "extension/language-configuration.json",
                   "extension/syntaxes/rmv.tmLanguage.json", "extension/snippets/rmv.json",
                   "extension/node_modules/vscode-languageclient/package.json"):  # fmt: skip
        assert wanted in names
    assert not any(n.startswith("extension/test/") for n in names)
    language = manifest["contributes"]["languages"][0]
    assert language["id"] == "rmv" and language["extensions"] == [".rmv"]
    settings = manifest["contributes"]["configuration"]["properties"]
    assert {"rmv.python", "rmv.server.command", "rmv.trace.server"} <= set(settings)
    snippets = json.loads((EXTENSION / "snippets" / "rmv.json").read_text(encoding="utf-8"))
    prefixes = {s["prefix"] for s in snippets.values()}
    declarations = {"topic", "var", "event", "transducer", "property", "alert", "whitelist",
                    "node", "intrusion", "database", "system"}  # fmt: skip
    assert declarations <= prefixes
    # the client starts the same server the LSP tests talk to
    assert '["-m", "rmvdsl.cli", "lsp"]' in (EXTENSION / "extension.js").read_text()
