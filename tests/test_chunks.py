"""`rmv replay --chunk` (docs/fleet.md, "Long recordings"): a recording replayed in
time chunks, each run starting a lead-in before its chunk, the chunks joined where
their runs' state keys meet and read on where they do not, gives exactly the result
of one run over the whole recording: the same records, each property's verdicts in
the same order, the same counters, status and message count. Any lead-in must give
that (a short one only reads on more), so the random cases draw it."""

from __future__ import annotations

import collections
import json
import random
import re
from pathlib import Path
from typing import Any

import differential
import fleet_recordings
import pytest
from conftest import EXAMPLES, rmv_process

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime import spec as ir
from rmvdsl.tools.fleet.sections import Job, Joined, plan
from rmvdsl.tools.fleet.worker import Options, replay_one

NS = 10**9


def _chunked(spec: ir.Spec, path: str, chunk: int, lead: int | None = None,
             options: Options | None = None) -> dict[str, Any]:  # fmt: skip
    """The joined result of the recording's sections, run one after another here."""
    options = options or Options()
    spec_json = ir.dump(spec, indent=None)
    sections = plan(path, spec, chunk, options.start, options.stop, lead)
    assert sections, "the recording should be longer than a chunk"
    join = Joined(path, sections, options.start is not None or options.stop is not None)
    jobs = [Job(path, section) for section in sections]
    index = 0
    while index < len(jobs):
        jobs.extend(join.add(jobs[index], replay_one(spec_json, jobs[index], options)))
        index += 1
    assert join.result is not None
    return join.result


def _same(whole: dict[str, Any], joined: dict[str, Any]) -> list[str]:
    """What differs between the whole run's result and the joined one (records of
    different kinds may interleave otherwise, as for any batching of the dataflow)."""
    problems = [f"{k}: {whole[k]!r} != {joined[k]!r}"
                for k in ("status", "violations", "intrusions", "warnings", "messages")
                if whole[k] != joined[k]]  # fmt: skip
    a, b = collections.Counter(whole["records"]), collections.Counter(joined["records"])
    if a != b:
        problems.append(f"only whole: {list((a - b).elements())[:4]}; "
                        f"only joined: {list((b - a).elements())[:4]}")  # fmt: skip
    if _verdicts(whole) != _verdicts(joined):
        problems.append("a property's verdicts come in another order")
    return problems


def _verdicts(result: dict[str, Any]) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for text in result["records"]:
        if text.startswith('{"kind": "verdict"'):
            out.setdefault(json.loads(text)["property"], []).append(text)
    return out


def _past_property(rng: random.Random, text: str) -> str:
    """A property that reads the past (the random specs' own look ahead only): a
    chunk's run must have the history its verdicts read back."""
    names = re.findall(r"^event (E\d+) when", text, re.M)
    names += re.search(r"states ([^\n]+)", text).group(1).split(", ")  # type: ignore[union-attr]
    a, b = rng.choice(names), rng.choice(names)
    formula = rng.choice([
        f"historically[<=1s] ({a} -> once[<=500ms] {b})", f"{a} since[<1s] {b}",
        f"once[<=700ms] {a} or not {b}", f"duration[500ms](once[<=300ms] {a}) < 0.2s",
    ])  # fmt: skip
    return f"property Past: {formula}\n"


def test_random_specs_and_recordings_chunked_equal_the_whole_run(tmp_path):
    """Random specs (events, a transducer, windows, rates, triggers) over random
    recordings in the three formats, cut at random chunk lengths with random
    lead-ins from none to longer than the recording."""
    rng = random.Random(20261127)
    cases = read_on = joined = 0
    for seed in range(16):
        case = differential.make_case(seed)
        case.text += _past_property(rng, case.text)
        spec = differential.runnable_spec(case, tmp_path)
        if spec is None:
            continue
        messages = differential.make_recording(rng, case.topics)
        if len({t for t, _, _ in messages}) < 3:
            continue
        kind = ("mcap", "db3", "bag")[seed % 3]
        path = str(
            differential.write_recording(tmp_path / f"case{seed}", kind, messages, case.topics)
        )
        whole = replay_one(ir.dump(spec, indent=None), path, Options())
        chunk = rng.choice([NS // 5, NS // 3, NS // 2, NS])
        lead = rng.choice([0, NS // 10, NS // 2, NS, 10 * NS])
        result_ = _chunked(spec, path, chunk, lead)
        assert not _same(whole, result_), (seed, chunk, lead, _same(whole, result_), case.text)
        cases += 1
        read_on += result_["seams_read_past"]
        joined += result_["chunks"] - 1 - result_["seams_read_past"]
    # The cases reach both ways of joining.
    assert cases >= 10 and read_on > 5 and joined > 5, (cases, read_on, joined)


@pytest.mark.parametrize("name", ["braking.bag", "braking_db3", "braking_mcap"])
def test_the_example_chunked_equals_the_whole_run(name):
    """abs.rmv (transducers, alerts, whitelists, a 75 s horizon) over its recordings:
    with its own lead-in (longer than the recording: every chunk's run starts at its
    start), with short ones that make runs read on past seams, and in a window."""
    spec = lower(check(str(EXAMPLES / "carla" / "abs.rmv")))
    path = str(EXAMPLES / "carla" / "recordings" / name)
    whole = replay_one(ir.dump(spec, indent=None), path, Options())
    assert whole["violations"] > 0
    chunk, lead, options = {
        "braking.bag": (3 * NS, 2 * NS, Options(start="+3", stop="+25")),
        "braking_db3": (7 * NS, None, Options()),
        "braking_mcap": (3 * NS, NS // 2, Options()),
    }[name]
    whole = replay_one(ir.dump(spec, indent=None), path, options)
    joined = _chunked(spec, path, chunk, lead, options)
    assert not _same(whole, joined), (chunk, lead, _same(whole, joined))
    assert joined["seams_read_past"] > 0 if lead is not None else True


@pytest.fixture(scope="module")
def long_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 1,000 s recording (10,000 messages, with stops and fast stretches) and the
    fleet tests' spec (4 s horizons: its lead-in is 8 s)."""
    folder = tmp_path_factory.mktemp("long")
    speeds = fleet_recordings.speeds(3, 10_000)
    for at in (1234, 6000, 8555):
        speeds[at] = 0.0
    speeds[5000:5030] = [30.0] * 30
    fleet_recordings.write(folder / "long", "mcap", speeds)
    (folder / "spec.rmv").write_text(fleet_recordings.SPEC, encoding="utf-8")
    return folder


def test_a_long_recording_in_chunks_on_two_processes(long_run):
    """`--chunk 100s --jobs 2`: ten chunks in two worker processes, joined by their
    keys; the result is the one run's, whose records `rmv replay` prints alone."""
    alone = rmv_process(["replay", "spec.rmv", "long_mcap", "--format", "json"], cwd=long_run)
    assert alone.code == 1, alone.err
    records = [json.dumps(r) for r in json.loads(alone.out)["records"]]
    chunked = rmv_process(["replay", "spec.rmv", "long_mcap", "--chunk", "100s", "--jobs", "2",
                           "--format", "jsonl"], cwd=long_run)  # fmt: skip
    assert chunked.code == 1, chunked.err
    result = json.loads(chunked.out)
    assert (result["chunks"], result["seams_read_past"], result["messages"]) == (10, 0, 10_000)
    joined = [json.dumps(r) for r in result["records"]]
    assert collections.Counter(joined) == collections.Counter(records)
    assert _verdicts({"records": joined}) == _verdicts({"records": records})
    text = rmv_process(["replay", "spec.rmv", "long_mcap", "--chunk", "5m", "--quiet"],
                       cwd=long_run)  # fmt: skip
    assert "4 chunks)" in text.out and "10,000 messages" in text.out, text.out


def test_chunk_durations_and_their_errors(long_run):
    bad = rmv_process(["replay", "spec.rmv", "long_mcap", "--chunk", "10 minutes"], cwd=long_run)
    assert bad.code == 2
    assert "--chunk: 10 minutes: give a duration of at least 1 ms" in bad.err, bad.err
    merged = rmv_process(["replay", "spec.rmv", "long_mcap", "--chunk", "1h", "--merge"],
                         cwd=long_run)  # fmt: skip
    assert merged.code == 2 and "leave out --merge" in merged.err, merged.err


def test_a_damaged_recording_chunked_says_what_the_whole_run_says(tmp_path):
    """A byte flipped so that the reader gives one message fewer than the recording
    lists: the joined result counts and reports it as the one run does."""
    good = fleet_recordings.write(tmp_path / "good", "mcap", fleet_recordings.speeds(1, 600))
    (tmp_path / "spec.rmv").write_text(fleet_recordings.SPEC, encoding="utf-8")
    spec = lower(check(str(tmp_path / "spec.rmv")))
    data = next(good.glob("*.mcap"))
    original = data.read_bytes()
    rng = random.Random(7)
    for _ in range(200):
        damaged = bytearray(original)
        damaged[rng.randrange(len(original))] ^= 0xFF
        data.write_bytes(bytes(damaged))
        whole = replay_one(ir.dump(spec, indent=None), str(good), Options())
        if whole["status"] == "incomplete" and any(
            "lists but cannot be read" in text for text in whole["records"]
        ):
            break
    else:
        pytest.fail("no flip lost a message")
    joined = _chunked(spec, str(good), 7 * NS, NS)
    assert not _same(whole, joined), _same(whole, joined)


def test_a_failed_chunk_fails_its_recording_once():
    """A section that fails (its worker died twice, it timed out twice) is the
    recording's result; the results of its other sections that come after it are
    not a second one."""
    from rmvdsl.tools import fleet
    from rmvdsl.tools.fleet.progress import Progress
    from rmvdsl.tools.fleet.worker import failed

    spec = lower(check(str(EXAMPLES / "carla" / "abs.rmv")))
    path = str(EXAMPLES / "carla" / "recordings" / "braking_mcap")
    given: list[tuple[int, dict[str, Any]]] = []
    settings = fleet.Settings(chunk=10 * NS)
    work = fleet.Work(spec, [path], settings, lambda i, r: given.append((i, r)),
                      Progress(None, 1, False))  # fmt: skip
    assert len(work.jobs) == 3
    spec_json = ir.dump(spec, indent=None)
    assert work.done(1, failed(path, "its worker died (SIGKILL), twice")) == []
    for index in (0, 2):
        assert work.done(index, replay_one(spec_json, work.jobs[index], Options())) == []
    assert [(i, r["status"], r["error"]) for i, r in given] == [
        (0, "failed", "its worker died (SIGKILL), twice")
    ]
