"""Every table keyed by a diagnostic's severity holds every severity: the language
server once lost a whole publication to a note its table did not know."""

from __future__ import annotations

import enum
import importlib
from pathlib import Path

import rmvdsl
from rmvdsl.lang.diagnostics import Severity

PACKAGE = Path(rmvdsl.__file__).parent


def _tables() -> list[tuple[str, str, set[enum.Enum]]]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if "Severity." not in path.read_text(encoding="utf-8"):
            continue
        name = ".".join(("rmvdsl", *path.relative_to(PACKAGE).with_suffix("").parts))
        module = importlib.import_module(name)
        for attribute, value in vars(module).items():
            if isinstance(value, dict) and value and all(isinstance(k, Severity) for k in value):
                found.append((name, attribute, set(value)))
    return found


def test_every_severity_table_is_total():
    tables = _tables()
    assert any(attribute == "SEVERITY" for _, attribute, _ in tables), tables
    for module, attribute, keys in tables:
        assert keys == set(Severity), f"{module}.{attribute} lacks {set(Severity) - keys}"
