"""The methods dataclasses writes, compiled once per machine (rmvdsl.util.compiled):
a process that finds them kept compiles none of rmvdsl's, makes the same classes
and gives the same output; a damaged, foreign or unwritable file only costs the
compiling; the file holds at most MAX_KEPT sources, the newest process's first."""

from __future__ import annotations

import json
import marshal
import os
import subprocess
import sys
from pathlib import Path

from conftest import EXAMPLES, RMV

from rmvdsl.grammar import ast
from rmvdsl.lang.source import Span
from rmvdsl.util import compiled

# Imports rmvdsl's stages in a new process (with dataclasses' plain exec, when asked),
# and says how many sources it compiled (dataclasses' exec is the kept code's: its
# `new` and `used`), what a frozen node, its equality, hash and repr give, and the
# code of every method dataclasses wrote for rmvdsl's classes.
PROBE = """
import dataclasses, json, sys
if sys.argv[1] == "plain":
    import builtins
    dataclasses.exec = builtins.exec
import rmvdsl.check, rmvdsl.check.analysis, rmvdsl.runtime.engine
from rmvdsl.grammar import ast
from rmvdsl.lang.source import Span
kept = getattr(dataclasses.exec, "__self__", None)  # builtins' exec: the module
kept = kept if hasattr(kept, "used") else None
one, two = ast.Ident("x", Span("a", 1, 2)), ast.Ident("x", Span("b", 3, 4))
try:
    one.name = "y"
    frozen = False
except dataclasses.FrozenInstanceError:
    frozen = True
methods = {}
for name, module in sorted(sys.modules.items()):
    if not name.startswith("rmvdsl."):
        continue
    for value in vars(module).values():
        if dataclasses.is_dataclass(value) and value.__module__ == name:
            for method in ("__init__", "__eq__", "__repr__", "__hash__", "__setattr__",
                           "__delattr__"):
                code = getattr(vars(value).get(method), "__code__", None)
                if code is not None:
                    found = vars(value)[method]
                    methods[f"{name}.{value.__qualname__}.{method}"] = [
                        code.co_code.hex(), code.co_flags, repr(code.co_consts),
                        code.co_names, repr(getattr(found, "__annotations__", None)),
                    ]
print(json.dumps({
    "new": kept and kept.new, "used": kept and len(kept.used), "methods": methods,
    "equal": one == two, "hash": hash(one) == hash(two), "repr": repr(one), "frozen": frozen,
}))
"""


def _probe(cache: Path | str, plain: bool = False) -> dict:
    env = {**os.environ, "RMV_CACHE_DIR": str(cache)}
    command = [sys.executable, "-c", PROBE, "plain" if plain else "kept"]
    run = subprocess.run(command, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def _kept_file(cache: Path) -> Path:
    (found,) = cache.glob("dataclasses-*.marshal")
    return found


def test_a_process_that_finds_the_code_kept_compiles_none_and_makes_the_same_classes(
    tmp_path: Path,
):
    first = _probe(tmp_path)
    assert first["new"] and first["used"] > 300  # rmvdsl's stages make hundreds of methods
    kept = marshal.loads(_kept_file(tmp_path).read_bytes())
    assert len(kept) >= first["used"]
    second = _probe(tmp_path)
    assert not second["new"], "the second process compiled what the first one kept"
    assert second["used"] == first["used"]
    plain = _probe(tmp_path / "none", plain=True)
    assert plain["new"] is None and len(plain["methods"]) > 300
    for found in (first, second):
        assert found["equal"] and found["hash"] and found["frozen"]
        assert found["repr"] == repr(ast.Ident("x", Span("a", 1, 2)))
        # the very methods Python writes alone: code, flags, constants, annotations
        assert found["methods"] == plain["methods"]


def test_the_commands_give_the_same_output_with_the_code_kept_and_without(tmp_path: Path):
    spec = str(EXAMPLES / "carla" / "abs.rmv")
    outputs = []
    for cache in ("", tmp_path / "cache", tmp_path / "cache"):  # none, written, read
        env = {**os.environ, "RMV_CACHE_DIR": str(cache), "NO_COLOR": "1"}
        check = subprocess.run([*RMV, "check", "--format", "json", spec], env=env,
                               capture_output=True, text=True)  # fmt: skip
        build = subprocess.run([*RMV, "build", "--target", "ir", spec], env=env,
                               capture_output=True, text=True)  # fmt: skip
        outputs.append((check.returncode, check.stdout, build.returncode, build.stdout))
    assert outputs[0][0] == 0 and outputs[0][2] == 0
    assert outputs[0] == outputs[1] == outputs[2]
    assert not list(Path(tmp_path).glob("*.marshal"))  # RMV_CACHE_DIR="": no files
    assert _kept_file(tmp_path / "cache").stat().st_size > 0


def test_a_damaged_or_foreign_file_only_costs_the_compiling(tmp_path: Path):
    _probe(tmp_path)
    path = _kept_file(tmp_path)
    whole = path.read_bytes()
    for damaged in (
        b"",
        whole[: len(whole) // 2],
        b"\x00garbage" * 100,
        marshal.dumps([1, 2, 3]),
        marshal.dumps({"def f(): pass": 1, 2: marshal.dumps(compile("x = 1", "<string>", "exec"))}),
        # a kept source whose code is not code, or not marshal's: every one of rmvdsl's
        marshal.dumps(dict.fromkeys(marshal.loads(whole), marshal.dumps(5))),
        marshal.dumps(dict.fromkeys(marshal.loads(whole), b"\xff\x00 not marshal")),
    ):
        path.write_bytes(damaged)
        found = _probe(tmp_path)
        assert found["new"] and found["equal"] and found["frozen"]
        assert len(marshal.loads(path.read_bytes())) >= found["used"]  # written anew


def test_an_unwritable_folder_only_costs_the_compiling(tmp_path: Path):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder", encoding="utf-8")
    found = _probe(blocked / "cache")  # a folder under a file: cannot be made
    assert found["new"] and found["equal"]


def test_the_file_keeps_at_most_max_kept_sources_this_process_s_first(tmp_path: Path, monkeypatch):
    path = tmp_path / "kept.marshal"
    old = {f"x{i} = {i}": marshal.dumps(compile(f"x{i} = {i}", "<string>", "exec"))
           for i in range(50)}  # fmt: skip
    path.write_bytes(marshal.dumps(old))
    monkeypatch.setattr(compiled, "MAX_KEPT", 30)
    kept = compiled._Kept(str(path))
    assert kept.codes.keys() == old.keys()
    namespace: dict = {}
    kept.exec("x1 = 1", {}, namespace)  # kept: not new
    assert not kept.new and namespace["x1"] == 1
    kept.exec("y = 2", {}, namespace)
    assert kept.new and namespace["y"] == 2
    kept.write()
    written = marshal.loads(path.read_bytes())
    assert list(written)[:2] == ["x1 = 1", "y = 2"]  # what this process used, first
    assert len(written) == 30
    assert list(written)[2:] == [k for k in old if k != "x1 = 1"][:28]


def test_code_another_user_wrote_is_never_run(tmp_path: Path, monkeypatch):
    """A cache folder shared with others: the file of code is read only when the user
    owns it (as if another user had written it: this process's uid said otherwise)."""
    path = tmp_path / "kept.marshal"
    planted = compile("import os; os.environ['RMV_PLANTED'] = '1'", "<string>", "exec")
    source = "x = 1"
    path.write_bytes(marshal.dumps({source: marshal.dumps(planted)}))
    assert compiled._Kept(str(path)).codes  # the user's own file: read
    real = os.getuid()
    monkeypatch.setattr(compiled.os, "getuid", lambda: real + 1)
    kept = compiled._Kept(str(path))
    assert kept.codes == {}
    namespace: dict = {}
    kept.exec(source, {}, namespace)
    assert namespace == {"x": 1} and "RMV_PLANTED" not in os.environ
    kept.write()  # written over with this process's code
    monkeypatch.setattr(compiled.os, "getuid", lambda: real)
    assert marshal.loads(compiled._Kept(str(path)).codes[source]).co_names == ("x",)
