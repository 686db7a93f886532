"""`rmv check`'s exact claims against the runtime on random whole specs and random
recordings (tests/differential.py; `python tests/differential.py --long`
is the long run). Each seed is one spec and three recordings."""

from __future__ import annotations

from pathlib import Path

import differential
import pytest

SEEDS = 300
BATCHES = 6


@pytest.mark.parametrize("batch", range(BATCHES))
def test_no_claim_of_the_checker_is_contradicted_by_the_runtime(batch, tmp_path: Path):
    size = SEEDS // BATCHES
    outcomes = [
        differential.examine(seed, tmp_path) for seed in range(batch * size, (batch + 1) * size)
    ]
    problems = [f"seed {o.seed}: {p}" for o in outcomes for p in o.problems]
    assert problems == []
    # The generator makes specs that check, and the checker claims things about them.
    assert sum(o.checked for o in outcomes) == size
    assert sum(o.claims for o in outcomes) >= size


def test_the_harness_finds_a_contradiction(tmp_path: Path, monkeypatch):
    """A runtime that passes through a state within an instant (the old transducer)
    contradicts `not (S0 and S1)`'s RMV512: the harness must see it."""
    from rmvdsl.runtime import engine

    def step(self, time, pulsed, emit):  # every state of the instant, as before
        for transition in self.transducer.transitions:
            if transition.source == self.state and (
                self.held.get(transition.input) or transition.input in pulsed
            ):
                self.state = transition.dest
                emit(time, self.name, self.state, self.name)
                emit(time, self.name, "S0" if self.state == "S1" else "S1", self.name)
                emit(time, self.name, self.state, self.name)
                return

    monkeypatch.setattr(engine.Transducer, "_step", step)
    case = differential.Case(
        0,
        'system s\nros humble\ntopic a: std_msgs/Bool = "/a"\nvar A = a.data\n'
        "event E when A\ntransducer T {\n states S0, S1\n initial S0\n S0 -> S1 on E\n"
        " S1 -> S0 on E\n}\nproperty P: not (S0 and S1)\n",
        {"/a": "Bool"},
        {"A": "/a"},
        [[(10**9, "/a", {"data": False}), (2 * 10**9, "/a", {"data": True})]],
    )
    result = differential.check_case(case, tmp_path)
    assert [d.code for d in result.diagnostics] == ["RMV512"]
    assert differential.contradictions(case, result)
