"""The registry of built-ins (rmvdsl.lang.builtins) is the one list: the checker accepts
exactly its names, lowering fills its defaults, docs/language.md's tables are
generated from it, and no code asks for a name it lacks.

Regenerate the tables of docs/language.md with `python -m rmvdsl.lang.builtins
docs/language.md`.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from conftest import ROOT

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.lang import builtins

_ACCESSORS = {"function", "action", "block", "setting"}


def _literal_uses() -> list[tuple[Path, int, str, tuple[str, ...]]]:
    """Every call with string literals of a registry accessor in rmvdsl/: the
    accessor and its literal arguments (`builtins.setting("qos", "depth")`,
    `self.settings("property", ...)`, `check_settings("alert", ...)`)."""
    found = []
    for path in sorted((ROOT / "rmvdsl").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Attribute):
                continue
            name = node.func.attr
            if name in _ACCESSORS and getattr(node.func.value, "id", "") == "builtins":
                kind = name
            elif name in ("settings", "check_settings"):
                kind = "block"
            else:
                continue
            literals = tuple(
                a.value
                for a in node.args
                if isinstance(a, ast.Constant) and isinstance(a.value, str)
            )
            if literals:
                found.append((path, node.lineno, kind, literals))
    return found


def test_no_code_asks_for_a_name_the_registry_lacks():
    uses = _literal_uses()
    assert len(uses) >= 8  # the scan finds the lowering's and the checker's lookups
    for path, line, kind, literals in uses:
        where = f"{path.relative_to(ROOT)}:{line}"
        try:
            if kind == "setting":
                builtins.setting(*literals[:2])
            else:
                getattr(builtins, kind)(literals[0])
        except builtins.UnknownBuiltin as exc:
            pytest.fail(f"{where} asks for {exc}")


def test_an_unknown_name_is_a_loud_bug():
    for ask in (
        lambda: builtins.function("histogram"),
        lambda: builtins.action("email"),
        lambda: builtins.setting("qos", "speed"),
        lambda: builtins.block("topic"),
    ):
        with pytest.raises(builtins.UnknownBuiltin):
            ask()


_SECOND = {"time": "1s", "count": "3", "percent": "95", "number": "2", None: "Speed"}


def test_the_checker_accepts_every_function_and_lowering_keeps_it(tmp_path):
    """One event per registered function, called with the arity and argument kinds
    the registry gives: the spec checks clean and lowers with the same names."""
    lines = [
        "system f",
        "ros humble",
        'topic t: std_msgs/msg/Float64 = "/t"',
        "var Speed = t.data",
    ]
    for name, function in builtins.FUNCTIONS.items():
        args = "Speed" if function.most == 1 else f"Speed, {_SECOND[function.second]}"
        # Aggregates need a window; transformations run over the raw points (RMV321).
        window = "" if function.group == "transformation" else " group by time(1s)"
        lines.append(f"event E_{name} = {name}({args}){window}")
    path = tmp_path / "functions.rmv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    result = check(str(path))
    assert not result.errors, [(d.code, d.message) for d in result.errors]
    spec = lower(result)
    called = {e.expr.function for e in spec.events if hasattr(e.expr, "function")}
    assert called == set(builtins.FUNCTIONS)


def test_the_checker_refuses_names_outside_the_registry(tmp_path):
    spec = tmp_path / "bad.rmv"
    spec.write_text(
        "system b\nros humble\n"
        'topic t: std_msgs/msg/Float64 = "/t"\n'
        "var Speed = t.data\n"
        "event H = histogram(Speed) group by time(1s)\n"
        'alert A {\n    crit when Speed > 1\n    action email("x")\n}\n',
        encoding="utf-8",
    )
    codes = {d.code for d in check(str(spec)).errors}
    assert {"RMV215", "RMV216"} <= codes


def test_every_entry_is_documented():
    for function in builtins.FUNCTIONS.values():
        assert function.doc and function.least <= function.most
    for action in builtins.ACTIONS.values():
        assert action.doc and all(p.doc for p in action.parameters.values())
        assert set(action.positional) <= set(action.parameters)
    for block in builtins.BLOCKS.values():
        for setting in block.settings.values():
            assert setting.doc and (setting.shown or setting.default is not None), setting.key
        assert set(block.required) <= set(block.settings)


def test_the_language_reference_tables_are_generated_from_the_registry():
    text = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    assert text == builtins.sync_reference(text)
    for name in (*builtins.BLOCKS, "functions", "actions"):
        assert f"<!-- builtins:{name} -->" in text, name


def test_every_function_with_any_count_of_arguments_anywhere_is_a_diagnostic(tmp_path):
    """Each registered function called with 0 to 3 arguments in a value, a
    condition and a `where` clause: the checker never raises (the names stage
    once unpacked `log`'s two arguments in a `where` before the types stage
    counted them; found by the fuzzer), and a count the registry refuses is
    RMV314."""
    head = ["system f", "ros humble", 'topic t: std_msgs/msg/Float64 = "/t"', "var Speed = t.data"]
    for name, function in builtins.FUNCTIONS.items():
        lines = list(head)
        for count in range(4):
            args = ", ".join(["Speed"] * count)
            lines += [
                f"event V{count} = max({name}({args})) group by time(1s)",
                f"event C{count} when {name}({args}) > 1",
                f"event W{count} = max(Speed) where {name}({args}) > 1 group by time(1s)",
            ]
        path = tmp_path / f"{name}.rmv"
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        codes = {d.code for d in check(str(path), use_environment=False).diagnostics}
        wrong = [c for c in range(4) if not function.least <= c <= function.most]
        assert not wrong or "RMV314" in codes, (name, codes)
