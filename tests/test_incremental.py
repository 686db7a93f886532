"""An incremental check (the editor's: each declaration's names and types reused
while its text and everything it looked up are unchanged, rmvdsl.check.memo) must
equal a check from scratch in everything a later stage or the editor reads: the
diagnostics, the symbols, every reference and where it points, every type."""

from __future__ import annotations

import random
import re
import shutil
from pathlib import Path
from typing import Any

import pytest
from conftest import EXAMPLES

from rmvdsl.check import CheckResult, check
from rmvdsl.grammar import ast
from rmvdsl.grammar.shift import findings

SPECS = sorted(
    p for p in EXAMPLES.rglob("*.rmv") if p.name != "latin1.rmv" and "imports" not in p.parts
)
# Pieces an edit inserts: syntax, units, whole declarations, and (added per spec)
# the spec's own names, so that an edit renames, redeclares and retypes.
PIECES = [
    "", "x", "1", "\n", " ", "}", "{", "(", ")", '"', "s", "ms", " and ", " > 2", "// ",
    "\nevent Z when X > 1\n", "\nvar W = T.f\n", "\ntime unit ms\n", "\nstates A, B\n",
    "\U0001f697", "-> eventually[<=2s] ",
]  # fmt: skip


def _summary(result: CheckResult) -> dict[str, Any]:
    """What a check found, in values a comparison can read (symbols by what they are,
    expression types by where their nodes are)."""
    model, types = result.model, result.types
    assert types is not None
    described = {n: (s.kind, s.span, s.owner) for n, s in model.symbols.items()}
    return {
        "diagnostics": result.diagnostics,
        "symbols": described,
        "references": [(r.name, r.span, described[r.symbol.name]) for r in model.references],
        "topics": types.topics,
        "variables": types.variables,
        "events": types.events,
        "horizons": types.horizons,
        "formulas": types.formulas,
        "expressions": [
            (node.span, type(node).__name__, types.type_of(node))
            for decl in model.declarations()
            for node in ast.walk(decl)
        ],
    }


def _same(path: Path, text: str) -> None:
    incremental = check(str(path), text, solver=False, incremental=True)
    fresh = check(str(path), text, solver=False)
    expected, found = _summary(fresh), _summary(incremental)
    for key, value in expected.items():
        assert found[key] == value, key


def _edited(text: str, rng: random.Random, pieces: list[str]) -> str:
    at = rng.randrange(len(text) + 1)
    if rng.random() < 0.2:  # delete a line
        start = text.rfind("\n", 0, at) + 1
        end = text.find("\n", at)
        return text[:start] + text[end + 1 if end >= 0 else len(text) :]
    cut = min(len(text), at + rng.randrange(4))
    return text[:at] + rng.choice(pieces) + text[cut:]


@pytest.fixture
def spec_copy(tmp_path: Path):
    """A copy of a spec's folder (its messages and rmv.toml beside it)."""

    def copy(spec: Path) -> Path:
        folder = tmp_path / spec.parent.name
        shutil.copytree(spec.parent, folder, ignore=shutil.ignore_patterns("recordings"))
        if (spec.parent.parent / "carla").is_dir():  # the error examples read ../carla/msg
            shutil.copytree(
                spec.parent.parent / "carla" / "msg", tmp_path / "carla" / "msg", dirs_exist_ok=True
            )
        return folder / spec.name

    return copy


@pytest.mark.parametrize("spec", SPECS, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_every_edit_checks_as_from_scratch(spec: Path, spec_copy) -> None:
    path = spec_copy(spec)
    text = path.read_text(encoding="utf-8")
    names = sorted(set(re.findall(r"\b[A-Za-z_][A-Za-z0-9_]*\b", text)))
    rng = random.Random(spec.name)
    pieces = PIECES + rng.sample(names, min(12, len(names)))
    _same(path, text)
    for _ in range(25):  # each edit on the last: what is remembered carries over
        text = _edited(text, rng, pieces)
        _same(path, text)


# Each way a declaration that did not change can still check differently, because
# something it looked up changed. (`before` is checked first, then `after`.)
DEPENDENCIES = {
    "a name it reads is gone": (
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent E when V > 1\n',
        'topic T: std_msgs/Float64 = "/t"\nvar U = T.data\nevent E when V > 1\n',
    ),
    "a name it reads is of another kind": (
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent E when V > 1\n',
        'topic T: std_msgs/Float64 = "/t"\nalert V { warn when T > 1 }\nevent E when V > 1\n',
    ),
    "a name it reads has another type": (
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent E when V > 1\n',
        'topic T: std_msgs/String = "/t"\nvar V = T.data\nevent E when V > 1\n',
    ),
    "an event it reads is now boolean": (
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent F = V * 2\nevent E when F > 1\n',
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent F when V > 2\n'
        "event E when F > 1\n",
    ),
    "the time unit changed": (
        "transducer D { states A, B\n initial A\n A -> B on E }\nevent E when 1 > 0\n"
        "property P: A -> eventually[<=2] B\n",
        "time unit s\ntransducer D { states A, B\n initial A\n A -> B on E }\n"
        "event E when 1 > 0\nproperty P: A -> eventually[<=2] B\n",
    ),
    "a state it names is now another transducer's": (
        "transducer D { states A, B\n initial A\n A -> B on E }\nevent E when 1 > 0\n",
        "transducer C { states A\n initial A }\n"
        "transducer D { states A, B\n initial A\n A -> B on E }\nevent E when 1 > 0\n",
    ),
    "a name it reads was in a declaration that did not parse": (
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data(\nevent E when V > 1\n',
        'topic T: std_msgs/Float64 = "/t"\nvar X = T.data\nevent E when V > 1\n',
    ),
    "an event it reads now closes a cycle": (
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent F = V * 2\nevent E = F + 1\n',
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent F = E * 2\nevent E = F + 1\n',
    ),
    "the events of a cycle moved by an edit before them": (
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nevent F = E * 2\nevent E = F + 1\n',
        'topic T: std_msgs/Float64 = "/t"\nvar V = T.data * 10\nevent F = E * 2\nevent E = F + 1\n',
    ),
}


@pytest.mark.parametrize("case", DEPENDENCIES, ids=str)
def test_a_declaration_is_checked_again_when_what_it_read_changed(case: str, tmp_path) -> None:
    before, after = DEPENDENCIES[case]
    path = tmp_path / "spec.rmv"
    _same(path, before)
    _same(path, after)
    _same(path, before)


def test_a_variable_is_typed_again_when_its_message_changed(tmp_path) -> None:
    """A variable's type comes from message definitions read from files: when a
    file changes, the variables reading that message are typed again."""
    folder = tmp_path / "msg" / "robot_msgs" / "msg"
    folder.mkdir(parents=True)
    definition = folder / "Speed.msg"
    path = tmp_path / "spec.rmv"
    text = (
        'messages "msg"\ntopic T: robot_msgs/Speed = "/speed"\nvar V = T.value\n'
        "event E when V > 1\n"
    )
    broken = b"float64 value\n\xff\n"  # not UTF-8: the file is reported, its type is broken
    for fields in (b"float64 value\n", b"string value\n", b"float64 other\n", broken, broken,
                   None, broken, None, b"float64 value\n"):  # fmt: skip
        if fields is None:  # no definition at all: the type is unknown (RMV300)
            definition.unlink()
        else:
            definition.write_bytes(fields)
        _same(path, text)


def test_a_variable_is_typed_again_when_a_message_along_its_path_changed(tmp_path) -> None:
    """The topic's own message unchanged, a message its path crosses changes: the
    variable reading through it is typed again (its kept lookup of that message)."""
    folder = tmp_path / "msg" / "robot_msgs" / "msg"
    folder.mkdir(parents=True)
    (folder / "Outer.msg").write_text("robot_msgs/Inner inner\n", encoding="utf-8")
    inner = folder / "Inner.msg"
    path = tmp_path / "spec.rmv"
    text = (
        'messages "msg"\ntopic T: robot_msgs/Outer = "/outer"\nvar V = T.inner.value\n'
        "event E when V > 1\n"
    )
    for fields in ("float64 value\n", "string value\n", "float64 other\n", "float64 value\n"):
        inner.write_text(fields, encoding="utf-8")
        _same(path, text)


def test_an_edit_reuses_the_declarations_it_did_not_touch(tmp_path) -> None:
    """The memo is used at all: after an edit to one event, every other
    declaration's findings are the very ones the check before kept (a check from
    scratch keeps none), and only the edited one's are new."""
    text = "".join(
        f'topic T{i}: std_msgs/Float64 = "/t{i}"\nvar V{i} = T{i}.data\nevent E{i} when V{i} > 1\n'
        for i in range(50)
    )
    path = tmp_path / "spec.rmv"
    first = _kept(check(str(path), text, solver=False, incremental=True))
    # names: every declaration; types: variables and events
    assert [len(first[stage]) for stage in ("names", "types")] == [150, 100]
    fresh = tmp_path / "other.rmv"  # another file: its own parse
    assert _kept(check(str(fresh), text, solver=False)) == {"names": {}, "types": {}}
    edited = text.replace("E7 when V7 > 1", "E7 when V7 > 12")
    second = _kept(check(str(path), edited, solver=False, incremental=True))
    for stage in ("names", "types"):
        assert second[stage].keys() == first[stage].keys()
        renewed = {n for n, found in second[stage].items() if found is not first[stage][n]}
        assert renewed == {"E7"}


def _kept(result: CheckResult) -> dict[str, dict[str, object]]:
    """Each stage's findings kept with each declaration's parse, by its name."""
    kept: dict[str, dict[str, object]] = {"names": {}, "types": {}}
    for decl in result.model.declarations():
        for (stage, _), found in (findings(decl) or {}).items():
            kept[stage][decl.name.name] = found  # type: ignore[attr-defined]
    return kept


def test_an_unknown_type_s_suggestion_is_worked_out_once_across_checks(tmp_path, monkeypatch):
    """An editor re-checks a spec whose messages are not there yet at every
    keystroke: each unknown type's did-you-mean is worked out once, not per check
    (50 unknown types took 13 ms of a 48 ms check)."""
    from rmvdsl.check import msgtypes

    asked: list[str] = []
    uncached = msgtypes.TypeRegistry._closest_uncached

    def counted(self: Any, full: str) -> str | None:
        asked.append(full)
        return uncached(self, full)

    monkeypatch.setattr(msgtypes.TypeRegistry, "_closest_uncached", counted)
    text = "".join(f'topic T{i}: sensor_msgs/LaserScna{i % 2} = "/t{i}"\n' for i in range(4))
    path = tmp_path / "spec.rmv"
    first = check(str(path), "system s\n" + text)
    again = check(str(path), "system s\n\n" + text)
    assert sorted(asked) == ["sensor_msgs/msg/LaserScna0", "sensor_msgs/msg/LaserScna1"]
    helps = [d.help for d in again.errors if d.code == "RMV300"]
    assert helps == [d.help for d in first.errors if d.code == "RMV300"]
    assert helps and all(h == "did you mean `sensor_msgs/msg/LaserScan`?" for h in helps)
