"""`rmv lsp` with a second, independent client: Debian's Neovim, headless, through
its built-in LSP client (tests/editor/nvim_client.lua)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

from conftest import RMV

from rmvdsl.editor.workspace import Workspace, formatted

CLIENT = Path(__file__).resolve().parent / "editor" / "nvim_client.lua"


def test_neovim_sees_diagnostics_hover_completion_definition_and_formats(tmp_path):
    nvim = shutil.which("nvim")
    assert nvim, "the editor tests need Debian's neovim (.ci/run installs it)"
    spec = tmp_path / "platoon.rmv"
    text = (
        "system   platoon\n"
        'topic t: std_msgs/msg/Float64 = "/t"\n'
        "var Speed = t.data\n"
        "event Fast when Speed > 30\n"
        "event Slow when Sped < 1\n"
        "property P: not Fast\n"
    )
    spec.write_text(text, encoding="utf-8")
    out = tmp_path / "seen.json"
    environment = {
        **os.environ,
        "RMV_LSP_COMMAND": json.dumps([*RMV, "lsp"]),
        "RMV_FILE": str(spec),
        "RMV_HOVER": f"3,{len('event Fast when ') + 1}",  # on `Speed`
        "RMV_COMPLETE": f"5,{len('property P: not ')}",
        "RMV_OUT": str(out),
        "XDG_CONFIG_HOME": str(tmp_path / "config"),
        "XDG_DATA_HOME": str(tmp_path / "data"),
        "XDG_STATE_HOME": str(tmp_path / "state"),
    }
    run = subprocess.run(
        [nvim, "--headless", "--clean", "-n", "-c", f"luafile {CLIENT}"],
        cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert out.exists(), run.stdout[-2000:] + run.stderr[-2000:]
    seen = json.loads(out.read_text(encoding="utf-8"))
    assert run.returncode == 0 and "error" not in seen, seen.get("error")

    expected = Workspace().check(str(spec))
    wanted = {(d.code, expected.model.sources.get(str(spec)).position(d.span.start).line - 1)  # type: ignore[union-attr]
              for d in expected.diagnostics}  # fmt: skip
    assert {(d["code"], d["lnum"]) for d in seen["diagnostics"]} <= wanted
    assert any(d["code"] == "RMV200" and d["lnum"] == 4 for d in seen["diagnostics"])
    assert "**variable** `Speed`" in seen["hover"]
    assert seen["definition"]["range"]["start"] == {"line": 2, "character": len("var ")}
    # In a formula: its operators and propositions, no variable, no InfluxQL function.
    assert {"Fast", "always", "eventually"} <= set(seen["completion"])
    assert not {"Speed", "mean"} & set(seen["completion"])
    assert seen["formatted"] == formatted(str(spec), text)
