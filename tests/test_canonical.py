"""Questions asked in their canonical naming (rmvdsl.logic.canonical): renaming
the propositions of a question changes neither its key nor its answer, a cached
answer comes back in the asker's names and replays there, and a spec that says
the same thing of two transducers asks the solver once."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_sat import formulas
from test_scaling import TWO_MACHINES

from rmvdsl.check import check
from rmvdsl.logic import sat
from rmvdsl.logic.answers import YES
from rmvdsl.logic.canonical import canonical
from rmvdsl.logic.limits import Limits
from rmvdsl.logic.sat import satisfiable, valid
from rmvdsl.logic.system import Machine, System
from rmvdsl.runtime.rmtld3 import Monitor, facts, merge
from rmvdsl.runtime.segments import verdict_at
from rmvdsl.util import cache as cache_module
from rmvdsl.util.cache import Cache

# Names a spec (or the canonical naming itself) may use: a real name equal to a
# canonical one must not be confused with it.
NAMES = ["p0", "p1", "p2", "m0", "a", "b", "c", "Robot_1_Idle", "\0machine M", "x"]


def machine(rename: dict[str, str]) -> System:
    a, b, c = (rename[n] for n in "abc")
    moves = frozenset({(a, b), (b, c), (c, a)})
    return System((Machine(rename["M"], (a, b, c), a, moves),))


def renamed(formula: Any, rename: dict[str, str]) -> Any:
    if formula[0] == "prop":
        return ("prop", rename[formula[1]])
    return tuple(renamed(c, rename) if isinstance(c, tuple) else c for c in formula)


def holds_on(formula: Any, answer: Any, expected: str = "true") -> bool:
    witness = answer.witness
    monitor = Monitor(formula)
    monitor.feed(zip(witness.times, witness.states, strict=True))
    monitor.end(witness.end)
    return verdict_at(merge(monitor.verdicts()), witness.at) == expected


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    formulas(2, st.integers(0, 3).map(Fraction)),
    st.permutations(NAMES),
    st.booleans(),
)
def test_a_renamed_question_is_the_same_question(formula, names, with_system):
    rename = dict(zip(["a", "b", "c", "M"], names, strict=False))
    other = renamed(formula, rename)
    system = machine({n: n for n in "abcM"}) if with_system else None
    system_renamed = machine(rename) if with_system else None
    first = canonical([formula], system, Limits())
    second = canonical([other], system_renamed, Limits())
    assert first.key == second.key
    assert first.formulas == second.formulas and first.system == second.system
    # asked once, then read from the cache in the other naming: the witness comes
    # back in the asker's names and replays on the asker's formula and system
    cache = Cache()
    answer = satisfiable([formula], system, cache=cache)
    again = satisfiable([other], system_renamed, cache=cache)
    assert again.value == answer.value
    fresh = satisfiable([other], system_renamed, cache=Cache())
    assert fresh.value == answer.value
    if again.value == YES:
        assert holds_on(other, again)
        props = {n for state in again.witness.states for n in state}
        assert props <= set(rename.values())
        if system_renamed is not None:
            names_used = system_renamed.names(set(facts(other).propositions))
            assert (
                system_renamed.violation(again.witness.times, again.witness.states, names_used)
                is None
            )
    counter = valid(other, system_renamed, cache=cache)
    if counter.witness is not None:
        assert holds_on(other, counter, "false")


def test_questions_that_differ_in_more_than_names_have_their_own_keys():
    system = machine({n: n for n in "abcM"})
    a, c = ("prop", "a"), ("prop", "c")
    soon = ("until", "<=", Fraction(1), ("const", True), c)
    # `a` is the initial state, `c` is not: no renaming makes one the other
    assert canonical([a], system, Limits()).key != canonical([c], system, Limits()).key
    assert canonical([soon], system, Limits()).key != canonical([soon], None, Limits()).key
    twice = ("and", a, ("prop", "b"))
    assert canonical([twice], None, Limits()).key != canonical([("and", a, a)], None, Limits()).key
    assert canonical([a], None, Limits()).key != canonical([a], None, Limits(timeout=1)).key


# test_scaling's two transducers of one shape, with their properties replaced
TWO_ALIKE = TWO_MACHINES[: TWO_MACHINES.index("property ")] + (
    "property Hold: always[<=5s] (A or B)\n"
    "property Vac: (A and B) -> eventually[<=1s] A\n"
    "property Hold2: always[<=5s] (C or D)\n"
    "property Vac2: (C and D) -> eventually[<=1s] C\n"
)


def test_a_spec_saying_one_thing_of_two_transducers_asks_the_solver_once(tmp_path, monkeypatch):
    asked: list[list[Any]] = []
    original = sat.ask

    def recording(formulas: Any, system: System, limits: Limits) -> Any:
        asked.append([list(formulas), system])
        return original(formulas, system, limits)

    monkeypatch.setattr(sat, "ask", recording)
    monkeypatch.setattr(cache_module, "_DEFAULT", Cache())  # empty: every question asked
    path = tmp_path / "spec.rmv"
    path.write_text(TWO_ALIKE, encoding="utf-8")
    found = check(str(path), use_environment=False, solver_jobs=1).diagnostics
    assert [(d.code, d.message.split(":")[0]) for d in found] == [
        ("RMV512", "property `Hold` holds on every trace of this system"),
        ("RMV513", "in property `Vac`, `A and B` can never hold"),
        ("RMV512", "property `Hold2` holds on every trace of this system"),
        ("RMV513", "in property `Vac2`, `C and D` can never hold"),
    ]
    questions = [repr(q) for q in asked]
    assert len(questions) == len(set(questions)), "a canonical question was asked twice"
    # the second transducer's properties were answered from the first's
    only_first = TWO_ALIKE.replace("property Hold2", "// ").replace("property Vac2", "// ")
    asked.clear()
    monkeypatch.setattr(cache_module, "_DEFAULT", Cache())
    path.write_text(only_first, encoding="utf-8")
    check(str(path), use_environment=False, solver_jobs=1)
    assert sorted(map(repr, asked)) == sorted(questions)


def test_a_check_renames_each_question_once(tmp_path, monkeypatch):
    """A check keys each question when it asks ahead and again when it reads the
    answer: the remembered canonical forms grow to the check's questions, so none
    is renamed twice (a fixed bound below them made a large spec's cached check
    take twice as long)."""
    from rmvdsl.logic import canonical as canonical_module
    from rmvdsl.util.bounded import Bounded

    monkeypatch.setattr(canonical_module, "_KEPT", Bounded(4))
    named: list[str] = []
    original = canonical_module._naming

    def recording(formulas: Any, system: System) -> Any:
        named.append(repr((list(formulas), system.key())))
        return original(formulas, system)

    monkeypatch.setattr(canonical_module, "_naming", recording)
    monkeypatch.setattr(cache_module, "_DEFAULT", Cache())
    path = tmp_path / "spec.rmv"
    properties = "".join(
        f"property P{i}: always[<={i + 1}s] (A or B) and (A -> eventually[<=2s] B)\n"
        for i in range(8)
    )
    path.write_text(TWO_MACHINES[: TWO_MACHINES.index("property ")] + properties, "utf-8")
    check(str(path), use_environment=False, solver_jobs=1)
    assert len(named) > 16
    assert len(named) == len(set(named))


def test_a_formula_deeper_than_the_stack_is_renamed_by_the_loop():
    """Recursion renames shallow formulas; one deeper than the stack allows (here
    on the test's own stack) is renamed by the loop, alike."""
    from rmvdsl.logic.canonical import _renamed_formula, _renamed_shallow

    shallow = ("until", "<=", Fraction(2), ("prop", "b"), ("not", ("prop", "a")))
    deep: Any = shallow
    for _ in range(5000):
        deep = ("not", deep)
    names = {"a": "p1", "b": "p0"}
    renamed = _renamed_formula(deep, names)
    for _ in range(5000):
        assert renamed[0] == "not"
        renamed = renamed[1]
    assert renamed == _renamed_shallow(shallow, names, {})
    assert renamed == ("until", "<=", Fraction(2), ("prop", "p0"), ("not", ("prop", "p1")))
