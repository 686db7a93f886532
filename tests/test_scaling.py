"""The checker's questions grow with the spec, not with its square (issue 15): the
questions on several properties are asked of the groups that share propositions,
exclusive events are looked for among events that read a common variable, and a
question's system is cut to what it mentions by index."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest

from rmvdsl.check import check, exclusion
from rmvdsl.check import properties as properties_module
from rmvdsl.check.conditions import Conditions
from rmvdsl.logic.system import Machine, System
from rmvdsl.runtime.rmtld3 import facts

TWO_MACHINES = """system s
ros humble
topic a: std_msgs/msg/Bool = "/a"
topic b: std_msgs/msg/Bool = "/b"
var X = a.data
var Y = b.data
event On when X
event Off when not X
event Up when Y
event Down when not Y
transducer T {
    states A, B
    initial A
    A -> B on On
    B -> A on Off
}
transducer U {
    states C, D
    initial C
    C -> D on Up
    D -> C on Down
}
property Soon: eventually[<=5s] B
property Stay: always[<=5s] A
property Late: eventually[<=5s] D
property Early: eventually[<=2s] D
"""


def joint_questions(monkeypatch: pytest.MonkeyPatch) -> list[set[str]]:
    """The propositions of every question the property analysis asks of more than
    one formula."""
    asked: list[set[str]] = []
    original = properties_module.satisfiable

    def recording(formulas: Any, *args: Any, **kwargs: Any) -> Any:
        if len(formulas) > 1:
            asked.append({n for f in formulas for n in facts(f).propositions})
        return original(formulas, *args, **kwargs)

    monkeypatch.setattr(properties_module, "satisfiable", recording)
    return asked


def codes(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "spec.rmv"
    path.write_text(text, encoding="utf-8")
    return [d.code for d in check(str(path), use_environment=False).diagnostics]


def test_questions_on_several_properties_are_asked_per_group(tmp_path, monkeypatch):
    """T's properties conflict; U's are consistent, and one implies the other: a
    conflict in one group no longer hides a redundancy in another, and no question
    mixes the two transducers' states."""
    asked = joint_questions(monkeypatch)
    assert codes(tmp_path, TWO_MACHINES) == ["RMV514", "RMV515"]
    assert asked, "the groups were asked nothing"
    for names in asked:
        assert names <= {"A", "B"} or names <= {"C", "D"}, names


def test_properties_that_look_into_the_past_are_asked_with_all_the_others(tmp_path, monkeypatch):
    """A past operator can bound the time of evaluation, which another group may
    need elsewhere: such properties are not split from the rest."""
    asked = joint_questions(monkeypatch)
    text = TWO_MACHINES.replace(
        "property Early: eventually[<=2s] D", "property Early: once[<=2s] D"
    )
    codes(tmp_path, text)
    assert any(names & {"A", "B"} and names & {"C", "D"} for names in asked), asked


def _questions(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """How many events each question of rmvdsl.check.exclusion asks at once."""
    asked: list[int] = []
    original = exclusion._Group._ask

    def counting(self: Any, events: list[str]) -> Any:
        asked.append(len(events))
        return original(self, events)

    monkeypatch.setattr(exclusion._Group, "_ask", counting)
    return asked


def _relations(tmp_path: Path, text: str, events: set[str]) -> tuple[Any, Conditions, System]:
    path = tmp_path / "spec.rmv"
    path.write_text(text, encoding="utf-8")
    result = check(str(path), use_environment=False)
    conditions = Conditions(result.model, result.types)
    system = properties_module.system_of(result.model, result.analysis, conditions, events, set())
    return result, conditions, system


def test_exclusive_events_are_looked_for_among_events_sharing_a_variable(tmp_path, monkeypatch):
    """On and Off read X, Up and Down read Y: two groups of two are asked, never a
    pair across them, and On, Off are still found exclusive."""
    asked = _questions(monkeypatch)
    text = TWO_MACHINES + "property Events: always[<=1s] (On or Off or Up or Down)\n"
    _, _, system = _relations(tmp_path, text, {"On", "Off", "Up", "Down"})
    assert max(asked) == 2
    assert {tuple(sorted(p)) for p in system.exclusive} == {("Off", "On"), ("Down", "Up")}


THRESHOLDS = """system many
topic t: std_msgs/msg/Float64 = "/t"
topic u: std_msgs/msg/Int32 = "/u"
var x = t.data
var n = u.data
"""


def test_events_over_one_variable_are_asked_in_linear_questions(tmp_path, monkeypatch):
    """400 thresholds on one variable were 80,000 pair questions: a model of them all
    joins every pair at once, so the questions are one per event at most."""
    count = 400
    asked = _questions(monkeypatch)
    events = "".join(f"event Above{k} when x > {k}\n" for k in range(count))
    prop = " or ".join(f"Above{k}" for k in range(count))
    text = THRESHOLDS + events + f"property Any: eventually[<=1s] ({prop})\n"
    _, _, system = _relations(tmp_path, text, {f"Above{k}" for k in range(count)})
    assert not system.exclusive and not system.never
    assert len(asked) <= count, len(asked)


# Events over two variables, some impossible, some bands that exclude each other,
# one reading both: the relations found at once equal the single questions'.
MIXED = [
    "x > 3", "x < 1", "x > 5 and x < 2", "x == 7.5", "x == 8", "x >= 7.5 and x <= 8",
    "n > 10", "n < -10", "n == 0", "n > 3 and x < 0", "x < 0", "n > 5 and n < 3",
    "x > 100", "not (x > 100)", "n >= 11 and n <= 11", "x != x",
]  # fmt: skip


def test_the_relations_found_at_once_are_the_single_questions_answers(tmp_path):
    names = [f"E{k}" for k in range(len(MIXED))]
    events = "".join(f"event {n} when {c}\n" for n, c in zip(names, MIXED, strict=True))
    prop = " or ".join(names)
    text = THRESHOLDS + events + f"property Any: eventually[<=1s] ({prop})\n"
    _, conditions, system = _relations(tmp_path, text, set(names))
    alone = {n for n in names if conditions.solve([conditions.of_event(n)], False)[0] == "unsat"}
    pairs = set()
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            if a in alone or b in alone:
                continue
            shared = conditions.names_of(conditions.of_event(a)) & conditions.names_of(
                conditions.of_event(b)
            )
            both = [conditions.of_event(a), conditions.of_event(b)]
            if shared and conditions.solve(both, False)[0] == "unsat":
                pairs.add((a, b))
    assert system.never == alone and alone == {"E2", "E11"}  # NaN != NaN: E15 holds
    assert {tuple(sorted(p)) for p in system.exclusive} == {tuple(sorted(p)) for p in pairs}
    assert ("E0", "E1") in pairs and ("E6", "E7") in pairs and ("E3", "E4") in pairs


def test_a_system_cut_to_some_names_is_the_naive_cut():
    """`relevant` and `restricted` by index give what scanning every transducer and
    every pair gives."""
    machines = tuple(
        Machine(f"M{i}", (f"S{i}a", f"S{i}b"), f"S{i}a", frozenset({(f"S{i}a", f"S{i}b")}))
        for i in range(50)
    )
    exclusive = frozenset({("E1", "E2"), ("E2", "E3"), ("S3a", "E4")})
    system = System(machines, exclusive, frozenset({"E5", "S7b"}))
    for names in ({"S3a", "E4", "E2"}, {"S7a", "E5", "S40b"}, {"E1", "E3"}, set()):
        relevant = tuple(m for m in machines if names & set(m.states))
        assert system.relevant(names) == relevant
        every = set(names).union(*(m.states for m in relevant))
        cut = system.restricted(names)
        assert cut.exclusive == {p for p in exclusive if p[0] in every and p[1] in every}
        assert cut.never == {n for n in system.never if n in every}


def many_groups(count: int) -> str:
    """`count` toggles, each with a consistent pair of properties (one implying
    the other) and, on the first, a conflicting one."""
    lines = ["system s", "ros humble", 'topic a: std_msgs/msg/Bool = "/a"', "var X = a.data"]
    lines += ["event On when X", "event Off when not X"]
    for i in range(count):
        lines += [f"transducer T{i} {{", f"    states A{i}, B{i}", f"    initial A{i}",
                  f"    A{i} -> B{i} on On", f"    B{i} -> A{i} on Off", "}"]  # fmt: skip
        lines.append(f"property Late{i}: eventually[<={i + 3}s] B{i}")
        lines.append(f"property Early{i}: eventually[<={i + 1}s] B{i}")
    lines.append("property Stay: always[<=20s] A0")
    return "\n".join(lines) + "\n"


def checked(tmp_path: Path, text: str, jobs: int) -> tuple[list[tuple[str, str, int]], Any]:
    from rmvdsl.util.cache import Cache, use_cache

    cache = Cache()
    use_cache(cache)
    try:
        path = tmp_path / "spec.rmv"
        path.write_text(text, encoding="utf-8")
        result = check(str(path), use_environment=False, solver_jobs=jobs)
    finally:
        use_cache(None)
    return [(d.code, d.message, d.span.start) for d in result.diagnostics], cache


def test_a_parallel_check_gives_the_sequential_answers_and_cache(tmp_path):
    """Worker processes answer the questions (they are running afterwards, ready
    for the next check); the diagnostics, and the questions kept in the cache with
    their answers, are those of the check with no worker."""
    from rmvdsl.logic import parallel

    text = many_groups(6)
    alone, alone_cache = checked(tmp_path, text, 1)
    together, together_cache = checked(tmp_path, text, 2)
    assert together == alone
    assert {c for c, _, _ in alone} == {"RMV514", "RMV515"}
    assert sum(c == "RMV515" for c, _, _ in alone) == 5  # T0's group conflicts
    assert together_cache.memory.keys() == alone_cache.memory.keys()
    assert {k: v.get("value", v.get("answer")) for k, v in together_cache.memory.items()} == {
        k: v.get("value", v.get("answer")) for k, v in alone_cache.memory.items()
    }
    assert sum(w.alive for w in parallel._WORKERS) == 2


def test_questions_a_worker_cannot_answer_are_asked_in_process(tmp_path, monkeypatch):
    """Workers that die at once (here: a program that is not Python) answer
    nothing; the check asks everything itself and says the same."""
    from rmvdsl.logic import parallel

    alone, _ = checked(tmp_path, many_groups(4), 1)
    parallel._stop_workers()
    monkeypatch.setattr(parallel.sys, "executable", "/bin/false")
    broken, _ = checked(tmp_path, many_groups(4), 2)
    assert broken == alone
    assert not any(w.alive for w in parallel._WORKERS)
    parallel._stop_workers()


def test_a_group_s_redundancy_is_read_from_the_cache_when_rechecking(tmp_path, monkeypatch):
    """The whole answer of a group is cached: re-checking neither asks the solver
    nor evaluates the known traces (once the editor's dearest step)."""
    from rmvdsl.logic import redundancy

    first, cache = checked(tmp_path, TWO_MACHINES, 1)

    def forbidden(*args: Any) -> None:
        raise AssertionError("evaluated the known traces again")

    monkeypatch.setattr(redundancy, "_KnownTraces", forbidden)
    from rmvdsl.util.cache import use_cache

    use_cache(cache)
    try:
        path = tmp_path / "spec.rmv"
        again = check(str(path), use_environment=False, solver_jobs=1)
    finally:
        use_cache(None)
    assert [(d.code, d.message, d.span.start) for d in again.diagnostics] == first
    assert "RMV515" in {c for c, _, _ in first}


def test_full_collections_are_rarer_while_checks_run_only(tmp_path):
    """The garbage collector's threshold is raised while any check runs (two at
    once included) and given back when the last ends."""
    import gc

    from rmvdsl.check import check, fewer_full_collections

    before = gc.get_threshold()
    with fewer_full_collections():
        assert gc.get_threshold()[2] >= 1000
        with fewer_full_collections():
            assert gc.get_threshold()[2] >= 1000
        assert gc.get_threshold()[2] >= 1000  # the outer one still runs
    assert gc.get_threshold() == before
    spec = tmp_path / "s.rmv"
    spec.write_text("system s\n", encoding="utf-8")
    check(str(spec), use_environment=False)
    assert gc.get_threshold() == before


def test_events_asked_together_get_the_answers_they_get_alone(tmp_path, monkeypatch):
    """rmvdsl.check.impossible asks a few dozen events in one question and halves a
    group z3 refuses: the events it calls impossible are exactly those a question
    of their own calls impossible, and possible events cost a question a group."""
    from rmvdsl.check import impossible as module

    conditions_ = [*MIXED, *(c.replace("7.5", "9.5").replace("x ", "-x ") for c in MIXED)]
    names = [f"E{k}" for k in range(len(conditions_))]
    events = "".join(f"event {n} when {c}\n" for n, c in zip(names, conditions_, strict=True))
    possible = [f"P{k}" for k in range(3 * module.TOGETHER)]
    events += "".join(f"event {p} when x > {k} or n < {k}\n" for k, p in enumerate(possible))
    prop = " or ".join([*names, *possible])
    text = THRESHOLDS + events + f"property Any: eventually[<=1s] ({prop})\n"
    _, conditions, _ = _relations(tmp_path, text, set())
    alone = {n: conditions.solve([conditions.of_event(n)], False)[0] == "unsat" for n in names}
    asked: list[int] = []
    verdict = Conditions.verdict
    monkeypatch.setattr(Conditions, "verdict", lambda s, c: asked.append(len(c)) or verdict(s, c))
    assert module.impossible(names, conditions) == alone
    assert {n for n, never in alone.items() if never} == {"E2", "E11", "E18", "E21", "E27"}
    asked.clear()
    assert module.impossible(possible, conditions) == dict.fromkeys(possible, False)
    assert asked == [module.TOGETHER] * 3
    # No answer in time makes no claim: the event is None, the others are answered.
    slow = conditions.of_event("E3")
    monkeypatch.setattr(
        Conditions,
        "verdict",
        lambda s, c: "unknown" if any(t.eq(slow) for t in c) else verdict(s, c),
    )
    assert module.impossible(names, conditions) == {**alone, "E3": None}


def test_an_antecedent_that_a_trace_at_hand_holds_is_not_asked(tmp_path, monkeypatch):
    """Each property's two traces (where it holds, where it fails) are at hand when
    its antecedents are asked about: the trace where `A -> eventually[<=5s] B`
    fails holds A, so "can A hold" needs no solver, and its answer is cached as the
    solver's would be. `A and B` holds on no trace (two states of one transducer):
    still asked, still reported vacuous."""
    from rmvdsl.logic import sat

    asked: list[list[Any]] = []
    original = sat.ask

    def recording(formulas: Any, *args: Any) -> Any:
        asked.append(list(formulas))
        return original(formulas, *args)

    monkeypatch.setattr(sat, "ask", recording)
    monkeypatch.setenv("RMV_CACHE_DIR", str(tmp_path / "cache"))
    text = (
        TWO_MACHINES
        + "property Goes: A -> eventually[<=5s] B\n"
        + "property Never: (A and B) -> eventually[<=1s] D\n"
    )
    path = tmp_path / "spec.rmv"
    path.write_text(text, encoding="utf-8")
    found = check(str(path), use_environment=False, solver_jobs=1).diagnostics
    vacuous = [d for d in found if d.code == "RMV513"]
    assert [d.message.split(",")[0] for d in vacuous] == ["in property `Never`"]
    alone = [f[0] for f in asked if len(f) == 1 and not facts(f[0]).future]
    # the solver sees questions in their canonical naming (rmvdsl.logic.canonical):
    # `A and B` is asked as `p0 and p1`
    assert [sorted(facts(f).propositions) for f in alone] == [["p0", "p1"]], asked
    again = check(str(path), use_environment=False, solver_jobs=1).diagnostics
    assert [d.code for d in again] == [d.code for d in found]


def test_a_worker_answers_an_antecedent_by_its_propertys_traces(tmp_path, monkeypatch):
    """A worker's batch is one property's questions: an antecedent marked so is
    answered by a trace of the property's (the one where it fails holds the
    antecedent), not asked; one no trace answers is asked."""
    from rmvdsl.logic import parallel
    from rmvdsl.logic.limits import Limits
    from rmvdsl.logic.system import Machine
    from rmvdsl.runtime.formulas import binary, const, not_, prop, temporal

    system = System((Machine("T", ("A", "B"), "A", frozenset({("A", "B"), ("B", "A")})),))
    a, b = prop("A"), prop("B")
    both = binary("and", a, b)
    goes = binary("or", not_(a), temporal("until", "<=", Fraction(5), const(True), b))
    from rmvdsl.logic import sat
    from rmvdsl.logic.canonical import canonical

    asked: list[Any] = []
    original = sat.ask

    def recording(formulas: Any, *args: Any) -> Any:
        asked.append(list(formulas))
        return original(formulas, *args)

    monkeypatch.setattr(sat, "ask", recording)
    batch = [([goes], system, False), ([("not", goes)], system, False),
             ([a], system, True), ([both], system, True)]  # fmt: skip
    answers = parallel._answer_batch(batch, Limits())
    # asked in their canonical naming (A is p0, B is p1 in each)
    expected = [
        list(canonical(q, system, Limits()).formulas) for q in ([goes], [("not", goes)], [both])
    ]
    assert asked == expected
    assert [x["value"] for x in answers] == ["yes", "yes", "yes", "no"]
    # a trace of the property's: the one where it fails holds A (the one where it
    # holds may too: z3's choice)
    assert answers[2]["witness"] in (answers[0]["witness"], answers[1]["witness"])
