"""Satisfiability and validity of RMTLD3 formulas in dense time (docs/verification.md).

A set of formulas is satisfiable when some complete trace makes all of them true
at one time (time 0 when no formula looks into the past or the system constrains
the start; any time otherwise). Two searches answer it, each sound on its side:

- a witness search: the system's constant traces, judged by the runtime's monitor,
  then traces with k segments and symbolic change times (`rmvdsl.logic.bounded`),
  k = 1, 2, 4, 8: a trace found is replayed through the monitor, and only a trace
  that replays is an answer ("yes", exact);
- a refutation in first-order logic over all functions of time
  (`rmvdsl.logic.abstract`): unsatisfiable there means no trace at all ("no", exact).

When neither succeeds the answer is "unknown", and says whether the witness search
was exhausted ("no witness with at most N changes", a bounded answer) or a time
limit cut it short. Answers are cached by formula.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rmvdsl.logic.abstract import refute
from rmvdsl.logic.answers import NO, UNKNOWN, YES, Answer, Witness
from rmvdsl.logic.canonical import Canonical, canonical, cut_system
from rmvdsl.logic.limits import Limits
from rmvdsl.logic.search import Question
from rmvdsl.logic.system import System
from rmvdsl.runtime.rmtld3 import facts
from rmvdsl.util.cache import Cache, default_cache, digest

# Answers read from the cache, decoded (a property's answers are read several
# times a check, and decoding a witness's times was a tenth of a first check's
# serial part): by key, with the cached entry they were decoded from.
_DECODED: dict[str, tuple[dict[str, Any], Answer]] = {}
DECODED_KEPT = 8192


def satisfiable(
    formulas: Sequence[Any],
    system: System | None = None,
    limits: Limits | None = None,
    cache: Cache | None = None,
    known: Sequence[Witness] = (),
) -> Answer:
    """Is there a trace of the system making all `formulas` true at one time?
    `known`: traces at hand, which answer yes where one does (`by_trace`) before
    the solver is asked; the answer is cached either way, in the question's
    canonical naming (rmvdsl.logic.canonical), and given in the caller's names."""
    limits = limits or Limits()
    cache = cache if cache is not None else default_cache()
    question = canonical(formulas, system, limits)
    cached = cached_answer(cache, question.key)
    if cached is not None:
        return question.real(cached)
    answer = solve(question, known, limits)
    keep(cache, question.key, answer)
    return question.real(answer)


def solve(question: Canonical, known: Sequence[Witness], limits: Limits) -> Answer:
    """The canonical answer to a canonical question: by a trace at hand (in the
    caller's names) where one answers, else by the solver."""
    answer = None
    if known:
        renamed = [question.canonical(w) for w in known]
        answer = by_trace(question.formulas, question.system, renamed, limits)
    return answer if answer is not None else ask(question.formulas, question.system, limits)


def question_key(
    formulas: Sequence[Any], system: System | None, limits: Limits
) -> tuple[str, System]:
    """The cache key of a question (of its canonical form), and the system cut to
    what the formulas mention."""
    question = canonical(formulas, system, limits)
    return question.key, question.restricted


def cached_answer(cache: Cache, key: str) -> Answer | None:
    found = cache.get(key)
    if found is None:
        return None
    decoded = _DECODED.get(key)
    if decoded is not None and decoded[0] is found:
        return decoded[1]
    try:
        answer = Answer.from_json(found)
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        return None  # an entry from elsewhere: ask again
    _remember(key, found, answer)
    return answer


def keep(cache: Cache, key: str, answer: Answer) -> None:
    """Cache an answer, unless a time limit cut it short: that depends on the
    machine, not on the question."""
    if not answer.timed_out:
        entry = answer.as_json()
        cache.put(key, entry)
        _remember(key, entry, answer)


def _remember(key: str, entry: dict[str, Any], answer: Answer) -> None:
    if len(_DECODED) >= DECODED_KEPT:
        _DECODED.clear()
    _DECODED[key] = (entry, answer)


def by_trace(
    formulas: Sequence[Any], system: System, known: Sequence[Witness], limits: Limits
) -> Answer | None:
    """The answer yes, with the trace as its witness, where one of `known` is a run
    of the system (`system` already restricted by question_key) on which the
    runtime's monitor finds every formula true at a time the question allows:
    time 0, or any time where the question's time is free; else None."""
    question = Question(list(formulas), system, limits)
    for witness in known:
        if (witness.at == 0 or question.free_time) and question.monitored(witness):
            return Answer(YES, True, witness)
    return None


def ask(formulas: Sequence[Any], system: System, limits: Limits) -> Answer:
    """The answer, from the solver (`system` already restricted by question_key)."""
    return Question(list(formulas), system, limits).answer()


def valid(
    formula: Any,
    system: System | None = None,
    limits: Limits | None = None,
    cache: Cache | None = None,
) -> Answer:
    """Is the formula true at every time of every trace of the system? A "no"
    comes with a counterexample: a trace where it is false."""
    negation = satisfiable([("not", formula)], system, limits, cache)
    flipped = {YES: NO, NO: YES, UNKNOWN: UNKNOWN}[negation.value]
    return Answer(
        flipped, negation.exact, negation.witness, note=negation.note, timed_out=negation.timed_out
    )


def conflict(formulas: Sequence[Any], system: System | None, limits: Limits) -> tuple[int, ...]:
    """A smallest subset of formulas that cannot hold together (each member needed:
    without any one of them the rest is not refuted), as indices; () when the
    whole set is not refuted. Of the subsets that are smallest in this sense, the
    one deletion in the formulas' order leaves, whatever z3's unsat cores: those
    depend on what the process asked z3 before, and a check with workers and one
    without reported different pairs of one conflicting group."""
    system = cut_system(formulas, system)
    # the members are indices: any naming of the question has the same ones
    key = digest("conflict", canonical(formulas, system, limits).key, "in order")
    cache = default_cache()
    cached = cache.get(key)
    if cached is not None and isinstance(cached.get("members"), list):
        return tuple(int(m) for m in cached["members"])
    members, complete = _smallest(formulas, system, limits)
    if complete:
        cache.put(key, {"members": list(members)})
    return members


def _smallest(
    formulas: Sequence[Any], system: System, limits: Limits
) -> tuple[tuple[int, ...], bool]:
    """Deletion-based minimisation, in the formulas' order; False when a limit cut a
    refutation short (then the result may not be the smallest, and is not cached).
    A subset a trace satisfies is no conflict: the witness search says so at once,
    where a refutation would search until its time limit (found by fuzzing: 5 s for
    `eventually[<11s] p and always[<10s] not p` alone)."""
    names = {n for f in formulas for n in system.names(set(facts(f).propositions))}
    members = list(range(len(formulas)))
    verdict, _ = refute(list(formulas), system, names, limits)
    if verdict != "unsat":
        return (), verdict != "limit"
    complete = True
    for candidate in list(members):
        rest = [m for m in members if m != candidate]
        if not rest:
            break
        if satisfiable([formulas[i] for i in rest], system, limits).value == YES:
            continue  # the rest can hold together: the candidate is in the conflict
        verdict, _ = refute([formulas[i] for i in rest], system, names, limits)
        if verdict == "unsat":
            members = rest
        complete = complete and verdict != "limit"
    return tuple(sorted(members)), complete
