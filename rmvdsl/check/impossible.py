"""Which boolean events no values make hold, asked many at a time.

One question an event cost about 10 ms on a large spec, most of it the question's
setting up (a solver, the terms translated into its context) rather than z3's
search. Events are asked together instead, a few dozen at once: one model makes
all of them hold, and each is possible. A group z3 refuses (or cannot answer in
time) is halved until each event is asked alone, so an impossible event costs a
few more questions and no event is called impossible but by its own "unsat".
Not all at once: z3's check grew faster than the question (1,000 float
conditions together took 65 s, asked 24 at a time 2 s).
"""

from __future__ import annotations

from typing import Any

from rmvdsl.check.conditions import Conditions

TOGETHER = 24  # events asked in one question


def impossible(events: list[str], conditions: Conditions) -> dict[str, bool | None]:
    """For each event: True when no values make it hold, False when some do, None
    when the solver gave no answer in time (no claim)."""
    answers: dict[str, bool | None] = {}
    for start in range(0, len(events), TOGETHER):
        part = events[start : start + TOGETHER]
        terms = [conditions.of_event(event) for event in part]
        _ask(part, terms, conditions, answers)
    return answers


def _ask(
    events: list[str], terms: list[Any], conditions: Conditions, answers: dict[str, bool | None]
) -> None:
    answer = conditions.verdict(terms)
    if answer == "sat":
        answers.update(dict.fromkeys(events, False))
    elif len(events) == 1:
        answers[events[0]] = True if answer == "unsat" else None
    else:  # one of them, or two together, cannot hold (or the time ran out)
        half = len(events) // 2
        _ask(events[:half], terms[:half], conditions, answers)
        _ask(events[half:], terms[half:], conditions, answers)
