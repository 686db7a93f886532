"""An editor's first answer to a keystroke inside one declaration, worked out from
the check before it (rmvdsl.check.edit), must be the fast stages' diagnostics of
the new text: over the examples' specs and random specs, with keys typed and
erased inside declarations (digits, the spec's own names, operators), each
answer that the edit path gives is compared with a check of the new text."""

from __future__ import annotations

import contextlib
import random
import re
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_incremental import SPECS, spec_copy  # noqa: F401 (a fixture)

from rmvdsl.check import CheckResult, check, edit
from rmvdsl.check.edit import check_edit
from rmvdsl.lang.diagnostics import Diagnostic, closest, may_sway, sort_key

sys.path.insert(0, str(Path(__file__).parent))
from differential import make_case

PIECES = ["1", "0", "7", " ", "x", "s", "ms", " and ", " > 2", "(", ")", "not ", ",", "_"]


def _order(diagnostic: Diagnostic) -> tuple[object, ...]:
    return (*sort_key(diagnostic), repr(diagnostic))


def _agrees(path: Path, before: CheckResult, text: str) -> tuple[bool, CheckResult]:
    """Whether the edit path answered (its answer checked), and the full check."""
    quick = check_edit(before, str(path), text)
    full = check(str(path), text, solver=False, incremental=True)
    if quick is not None:
        assert sorted(quick.diagnostics, key=_order) == sorted(full.diagnostics, key=_order)
        source = quick.sources.get(str(path))
        assert source is not None and source.text == text
    return quick is not None, full


def _typed_inside(result: CheckResult, text: str, rng: random.Random, names: list[str]) -> str:
    """A key typed, or one to three erased, inside a declaration of the root file."""
    decls = result.model.specs[0].items if result.model.specs else ()
    if not decls:
        return text + rng.choice(PIECES)
    span = rng.choice(decls).span
    at = rng.randrange(span.start, span.end + 1)
    if rng.random() < 0.35:
        return text[:at] + text[at + rng.randint(1, 3) :]
    return text[:at] + rng.choice([*PIECES, *names]) + text[at:]


def _typed_in_two(result: CheckResult, text: str, rng: random.Random, names: list[str]) -> str:
    """A key typed, or one to three erased, in each of two declarations of the root
    file (the later first, so the earlier's place stands): what the check before
    last sees when the fast stages of the keys between were not run."""
    decls = result.model.specs[0].items if result.model.specs else ()
    if len(decls) < 2:
        return _typed_inside(result, text, rng, names)
    for span in sorted((d.span for d in rng.sample(decls, 2)), key=lambda s: -s.start):
        at = rng.randrange(span.start, span.end + 1)
        if rng.random() < 0.35:
            text = text[:at] + text[at + rng.randint(1, 3) :]
        else:
            text = text[:at] + rng.choice([*PIECES, *names]) + text[at:]
    return text


def _session(path: Path, text: str, rng: random.Random, edits: int) -> tuple[int, int]:
    """Keys typed and then erased (the text before them again, from the check of
    the text with them), two at a time now and then: how many of the changes the
    edit path answered, of how many."""
    names = sorted(set(re.findall(r"\b[A-Za-z_][A-Za-z0-9_]*\b", text)))[:40]
    path.write_text(text, encoding="utf-8")
    base = check(str(path), text, solver=False, incremental=True)
    answered = 0
    for _ in range(edits):
        edited = _typed_inside(base, text, rng, names)
        quick, result = _agrees(path, base, edited)
        if rng.random() < 0.3:  # a second key on the first
            again, result = _agrees(path, result, _typed_inside(result, edited, rng, names))
            answered += again
        back, base = _agrees(path, result, text)
        answered += quick + back
    return answered, edits * 2


@pytest.mark.parametrize("spec", SPECS, ids=lambda p: p.name)
def test_keys_in_the_examples_specs(spec: Path, spec_copy) -> None:  # noqa: F811
    path = spec_copy(spec)
    _session(path, path.read_text(encoding="utf-8"), random.Random(spec.name), 25)


def test_keys_in_random_specs(tmp_path: Path) -> None:
    """Random specs of the differential test. Many random keys break what a
    declaration declares, or run into a topic's declaration (the full check
    answers those); the edit path answered 262 of these 1,200 changes when this
    was written."""
    answered = total = 0
    for seed in range(40):
        case = make_case(seed)
        found, edits = _session(tmp_path / f"s{seed}.rmv", case.text, random.Random(seed), 15)
        answered, total = answered + found, total + edits
    assert answered >= total * 0.05, (answered, total)


@pytest.mark.parametrize("most", [edit._MOST_CHUNKS, 2])
def test_keys_in_two_places_of_random_specs(tmp_path: Path, most: int, monkeypatch) -> None:
    """Two declarations changed at once, anywhere in the spec (a typist's keys in
    one place and the first in another, before the fast stages of the first ran;
    an edit of several cursors): each answer agrees with the full check, and some
    are given. The random specs are short: with at most 2 chunks changed, edits
    more than 2 chunks apart are matched chunk by chunk (47 of these 400 answered
    so when this was written; with 8, 61)."""
    monkeypatch.setattr(edit, "_MOST_CHUNKS", most)
    answered = total = 0
    for seed in range(40):
        case = make_case(seed)
        path = tmp_path / f"two{seed}.rmv"
        path.write_text(case.text, encoding="utf-8")
        base = check(str(path), case.text, solver=False, incremental=True)
        rng = random.Random(seed)
        names = sorted(set(re.findall(r"\b[A-Za-z_][A-Za-z0-9_]*\b", case.text)))[:40]
        for _ in range(10):
            quick, _ = _agrees(path, base, _typed_in_two(base, case.text, rng, names))
            answered, total = answered + quick, total + 1
    assert answered >= total * 0.08, (answered, total)


def test_digits_typed_in_two_declarations_far_apart(tmp_path: Path) -> None:
    """A bound typed in the first event and a threshold in one 40 declarations
    on, answered from the check before both: a diagnostic between them is moved
    by the first edit, one after both (and a label on a name declared there, read
    by the second) by both."""
    events = "".join(f"event E{i} when V > {i}\n" for i in range(40))
    reads = " and ".join(f"not E{i}" for i in range(40))
    spec = HEAD + events + f"property P: always[<=1s] ({reads})\n"
    spec += "event Lone when W > 3 and Late > 1\nevent Unused when W > 4\n"
    spec += "property Late: always[<=1s] not E1\n"
    spec = spec.replace("event E20 when V > 20", "event E20 when V > 20 and Wq > 1")
    first, last = spec.index("V > 0") + 4, spec.index("W > 3") + 4
    edited = spec[:first] + "7" + spec[first:last] + "1" + spec[last:]
    answered, full = _pair(tmp_path, spec, edited)
    assert answered
    assert {d.code for d in full.diagnostics} == {"RMV200", "RMV202", "RMV203"}


def test_a_digit_typed_in_any_number_of_an_event_or_a_property(tmp_path: Path) -> None:
    """What a typist does most (a bound, a threshold, a rate): the edit path answers
    every such key in the random specs, and agrees."""
    for seed in range(20):
        text = make_case(seed).text
        path = tmp_path / f"d{seed}.rmv"
        path.write_text(text, encoding="utf-8")
        base = check(str(path), text, solver=False, incremental=True)
        for match in re.finditer(r"^(?:event|property) .*$", text, re.MULTILINE):
            for digit in re.finditer(r"\b\d", match.group()):  # not in a name
                at = match.start() + digit.end()
                answered, _ = _agrees(path, base, text[:at] + "7" + text[at:])
                assert answered, (seed, text[match.start() : match.end()])


HEAD = 'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\nvar W = T.data\n'


def _pair(tmp_path: Path, before: str, after: str) -> tuple[bool, CheckResult]:
    path = tmp_path / "pair.rmv"
    path.write_text(before, encoding="utf-8")
    return _agrees(path, check(str(path), before, solver=False, incremental=True), after)


def test_a_name_no_longer_read_is_unused_and_read_again_is_not(tmp_path: Path) -> None:
    spec = HEAD + "event B when V > 1 and W < 2\nproperty P: always[<=1s] not B\n"
    answered, full = _pair(tmp_path, spec, spec.replace("W < 2", "W7 < 2"))
    assert answered
    assert {"RMV200", "RMV203"} <= {d.code for d in full.diagnostics}
    answered, full = _pair(tmp_path, spec.replace("W < 2", "W7 < 2"), spec)
    assert answered and full.diagnostics == []


def test_a_declaration_typed_a_key_at_a_time(tmp_path: Path) -> None:
    """Most of its texts have a syntax error, which quiets "undefined name" for
    the names in it and every "never used": the edit path answers most keys (36
    of 44 when this was written, 4 before it followed syntax errors)."""
    spec = HEAD + "event F when V > 1\nproperty P: always[<=1s] not F\n"
    path = tmp_path / "typed.rmv"
    row = spec.index("property")
    typed = "event Znew when W > 2"  # on a line of its own
    texts = [spec[:row] + typed[:k] + "\n" + spec[row:] for k in range(len(typed) + 1)]
    texts += [*texts[-2::-1], spec]  # and erased
    before = check(str(path), spec, solver=False, incremental=True)
    answered = 0
    for text in texts:
        quick, before = _agrees(path, before, text)
        answered += quick
    assert answered >= len(texts) * 0.6, (answered, len(texts))


def test_a_syntax_error_quieting_a_name_read_elsewhere_waits_for_the_full_check(
    tmp_path: Path,
) -> None:
    """`Zq` is read and not declared: RMV200 in E, until a chunk with a syntax
    error holds the name (it may have declared it)."""
    spec = HEAD + "event E when Zq > 1\nevent F when V > 1\nproperty P: not (E or F)\n"
    answered, full = _pair(tmp_path, spec, spec.replace("V > 1", "V > Zq +"))
    assert not answered and "RMV200" not in {d.code for d in full.diagnostics}


def test_a_declaration_added_or_removed(tmp_path: Path) -> None:
    """A new event no one reads (it is unused, and W it reads no longer is); and
    back. A name read in vain elsewhere keeps the edit path away (its "did you
    mean" chooses among the names)."""
    spec = HEAD + "event F when V > 1\nproperty P: always[<=1s] not F\n"
    added = spec.replace("event F when V > 1\n", "event F when V > 1\nevent H when W > 1\n")
    answered, full = _pair(tmp_path, spec, added)
    assert answered and [d.code for d in full.diagnostics] == ["RMV203"]
    answered, full = _pair(tmp_path, added, spec)
    assert answered and [d.code for d in full.diagnostics] == ["RMV203"]
    in_vain = spec.replace("not F", "not F and not Hx")
    answered, _ = _pair(
        tmp_path, in_vain, in_vain.replace("event F", "event H when W > 1\nevent F")
    )
    assert not answered


def test_a_declaration_added_or_removed_beside_a_name_read_in_vain_it_is_not_near(
    tmp_path: Path,
) -> None:
    """A name read in vain elsewhere whose "did you mean" the new name cannot be
    nor sway (too far from it) leaves the edit path the answer. Refused, every
    declaration typed while some name elsewhere was wrong ran the full fast stages
    (at 20,805 lines, 170-300 ms a key)."""
    spec = HEAD + "event F when V > 1\nproperty P: always[<=1s] not F and not Qzzq\n"
    added = spec.replace("event F", "event Hnew when W > 1\nevent F")
    for before, after in ((spec, added), (added, spec)):
        answered, full = _pair(tmp_path, before, after)
        assert answered
        assert "RMV200" in {d.code for d in full.diagnostics}
    near = spec.replace("event F", "event Qzzp when W > 1\nevent F")  # its suggestion now
    answered, full = _pair(tmp_path, spec, near)
    assert not answered
    assert any(d.help == "did you mean `Qzzp`?" for d in full.diagnostics)
    answered, _ = _pair(tmp_path, spec, spec.replace("event F", "event Qzzq when W > 1\nevent F"))
    assert not answered  # the name read in vain is declared now


_NAMES = st.text(alphabet="abAB_1", min_size=0, max_size=7)


@settings(max_examples=400, deadline=None)
@given(_NAMES, st.lists(_NAMES, max_size=6), _NAMES, st.integers(min_value=0, max_value=6))
def test_a_name_that_cannot_sway_a_suggestion_leaves_it_as_it_was(
    wrong: str, names: list[str], added: str, at: int
) -> None:
    """What same_interface relies on: a candidate may_sway says no to changes no
    "did you mean", wherever it stands among the others."""
    if may_sway(wrong, added):
        return
    assert closest(wrong, names) == closest(wrong, [*names[:at], added, *names[at:]])


def test_an_edit_closing_a_cycle_waits_for_the_full_check(tmp_path: Path) -> None:
    spec = HEAD + "event F = V * 2\nevent E = F + 1\nevent G when E > 1\nproperty P: not G\n"
    answered, full = _pair(tmp_path, spec, spec.replace("F = V * 2", "F = E * 2"))
    assert not answered and "RMV220" in {d.code for d in full.diagnostics}


def test_an_edit_reading_an_emitted_event_that_closes_a_cycle_waits_too(tmp_path: Path) -> None:
    """An emitted event stands for its transducer in the cycles (X for D): E reads
    X, and D steps on E. The edit path followed X as a name of its own and answered
    with no RMV220."""
    spec = HEAD + "event E when V > 1\ntransducer D {\n    states A, B\n    initial A\n"
    spec += "    A -> B on E emit X\n}\nproperty P: always[<=1s] not B\n"
    answered, full = _pair(tmp_path, spec, spec.replace("V > 1", "V > 1 and X"))
    assert not answered and "RMV220" in {d.code for d in full.diagnostics}


def test_a_diagnostic_after_the_edit_moves_its_own_labels_only(tmp_path: Path) -> None:
    """RMV202 in the last event points back at the topic, before the edit."""
    spec = HEAD + "event F when V > 1\nevent E when T > 1\nproperty P: F or E\n"
    answered, full = _pair(tmp_path, spec, spec.replace("V > 1", "V > 12.5"))
    assert answered
    [wrong] = [d for d in full.diagnostics if d.code == "RMV202"]
    assert wrong.secondary and wrong.secondary[0].span.start < wrong.span.start


@pytest.mark.parametrize(
    "before, after",
    [
        ("event F when V > 1", "event G when V > 1"),  # a declared name
        ("event F when V > 1", "event F = V + 1"),  # a boolean event made a value
        ("event F when V > 1", "event F when V > 1\nevent V when W > 1"),  # a name again
    ],
)
def test_edits_past_one_declaration_wait_for_the_full_check(
    tmp_path: Path, before: str, after: str
) -> None:
    spec = HEAD + "event F when V > 1\nproperty P: always[<=1s] not F\n"
    answered, _ = _pair(tmp_path, spec, spec.replace(before, after))
    assert not answered


SERVED = 'topic T: std_msgs/Float64 = "/t"\nvar V = T.data\n'


@contextlib.contextmanager
def _served(tmp_path: Path, text: str, first: Any = None) -> Iterator[tuple[Any, str]]:
    """A server in this process with `text` open, its first diagnostics (those
    `first` accepts) come: the wire and the document's uri."""
    from lsp_wire import Wire

    wire = Wire(in_process=True)
    try:
        wire.initialize(tmp_path)
        uri = wire.open(tmp_path / "served.rmv", text)
        wire.diagnostics_until(uri, first or (lambda p: p["version"] == 1), timeout=60)
        yield wire, uri
    finally:
        wire.close()


def test_the_server_answers_a_key_while_its_fast_lane_is_busy(tmp_path: Path) -> None:
    """The first diagnostics of a key inside a declaration do not wait for the
    fast stages: with their lane held busy, the key's diagnostics still come."""
    from test_lsp_edges import _edit

    busy = threading.Event()
    text = SERVED + "event E when V > 100\nproperty P: always[<=1s] not E\n"
    with _served(tmp_path, text, lambda p: p["version"] == 1 and p["diagnostics"] == []) as (
        wire,
        uri,
    ):
        try:
            wire.process.server.state.fast_lane.submit(busy.wait, 120)
            start = len("event E when ")
            wire.notify("textDocument/didChange", _edit(uri, 2, 2, start, start + 1, "Q"))
            found = wire.diagnostics_until(uri, lambda p: p["version"] == 2, timeout=20)
            by_code = {d["code"]: d["range"]["start"] for d in found["diagnostics"]}
            assert by_code == {  # `Q` is not declared, and `V` is no longer read
                "RMV200": {"line": 2, "character": start},
                "RMV203": {"line": 1, "character": 4},
            }
        finally:
            busy.set()


def test_a_key_overtaken_while_the_edit_lane_is_busy_is_not_worked_out(tmp_path: Path) -> None:
    """Keys typed while the edit lane is busy (a typist asking for completion does
    not wait for diagnostics) leave the lane only the newest to work out: each
    overtaken key's answer was worked out all the same, and the next key waited
    for them all (1.8 s at 20,805 lines)."""
    from test_lsp_edges import _edit

    busy = threading.Event()
    text = SERVED + "event E when V > 100\nproperty P: always[<=1s] not E\n"
    with _served(tmp_path, text, lambda p: p["version"] == 1 and p["diagnostics"] == []) as (
        wire,
        uri,
    ):
        state = wire.process.server.state
        asked: list[str] = []
        real = state.workspace.check_edit

        def counted(path: str, edited: str, before: CheckResult) -> Any:
            asked.append(edited)
            return real(path, edited, before)

        state.workspace.check_edit = counted
        try:
            state.edit_lane.submit(busy.wait, 120)
            start = len("event E when V > ")
            for version, digit in enumerate("12345", start=2):
                at = start + version - 2
                wire.notify("textDocument/didChange", _edit(uri, version, 2, at, at, digit))
            deadline = time.monotonic() + 20
            while max(state.generation.values()) < 6 and time.monotonic() < deadline:
                time.sleep(0.01)  # until the five keys have come
        finally:
            busy.set()
        found = wire.diagnostics_until(uri, lambda p: p["version"] == 6, timeout=20)
        assert found["diagnostics"] == []
        assert asked == [text.replace("V > 100", "V > 12345100")], asked


def test_the_fast_stages_of_keys_the_edit_path_answered_wait_for_a_pause(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Keys typed faster than SETTLE, each answered by the edit path, run the fast
    stages once, on the last text: run at each key, they held the interpreter from
    the completions sent meanwhile (at 20,805 lines, 300 ms of CPU a key; didChange
    p99 122 ms there, 38 ms with them waiting)."""
    from test_lsp_edges import _edit

    from rmvdsl.editor.lsp import session

    monkeypatch.setattr(session, "SETTLE", 2.0)  # keys far quicker, on a loaded machine too
    text = SERVED + "event E when V > 100\nproperty P: always[<=1s] not E\n"
    with _served(tmp_path, text, lambda p: p["version"] == 1 and p["diagnostics"] == []) as (
        wire,
        uri,
    ):
        workspace = wire.process.server.state.workspace
        checked: list[str] = []
        real = workspace.check

        def counted(path: str, *args: Any, **options: Any) -> Any:
            checked.append(workspace.documents()[path])
            return real(path, *args, **options)

        workspace.check = counted
        start = len("event E when V > ")
        for version, digit in enumerate("1234", start=2):
            at = start + version - 2
            wire.notify("textDocument/didChange", _edit(uri, version, 2, at, at, digit))
            found = wire.diagnostics_until(uri, lambda p, v=version: p["version"] == v)
            assert found["diagnostics"] == []
        wire.call("textDocument/hover", {"textDocument": {"uri": uri},
                                         "position": {"line": 2, "character": 6}})  # fmt: skip
        assert checked == [text.replace("V > 100", "V > 1234100")], checked


_EVENTS = "".join(f"event E{k} when V > {k}\n" for k in range(20))
FAR_APART = (
    SERVED + _EVENTS + f"property P: always[<=1s] not ({' or '.join(f'E{k}' for k in range(20))})\n"
)
_NEAR, _FAR = len("event E0 when V > "), len("event E19 when V > ")  # on lines 2 and 21


@dataclass
class _Watched:
    """A served document and what its server did: the texts its fast stages
    checked, and whether each answer of its edit path was far; the edit path stops
    at `held` (set when it has) until `gate` opens."""

    wire: Any
    uri: str
    checked: list[str] = field(default_factory=list)
    answered: list[bool] = field(default_factory=list)
    held: threading.Event = field(default_factory=threading.Event)
    gate: threading.Event = field(default_factory=threading.Event)


@contextlib.contextmanager
def _far_apart(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, hold: str | None = None
) -> Iterator[_Watched]:
    """FAR_APART served, its first key typed in E0 and answered, and no pause for
    the fast stages (SETTLE a minute); the edit path held at a text holding `hold`."""
    from test_lsp_edges import _edit

    from rmvdsl.editor.lsp import session

    monkeypatch.setattr(session, "SETTLE", 60.0)
    with _served(tmp_path, FAR_APART, lambda p: p["version"] == 1) as (wire, uri):
        watched = _Watched(wire, uri)
        workspace = wire.process.server.state.workspace
        check, check_edit = workspace.check, workspace.check_edit

        def counted(path: str, *args: Any, **options: Any) -> Any:
            watched.checked.append(workspace.documents()[path])
            return check(path, *args, **options)

        def recorded(path: str, edited: str, before: CheckResult) -> Any:
            if hold is not None and hold in edited:
                watched.held.set()
                watched.gate.wait(60)
            found = check_edit(path, edited, before)
            watched.answered.append(found is not None and found.far)
            return found

        workspace.check, workspace.check_edit = counted, recorded
        try:
            wire.notify("textDocument/didChange", _edit(uri, 2, 2, _NEAR, _NEAR, "7"))
            wire.diagnostics_until(uri, lambda p: p["version"] == 2)
            yield watched
        finally:
            watched.gate.set()


def _until(condition: Any, seconds: float = 30) -> None:
    deadline = time.monotonic() + seconds
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert condition()


def test_a_key_far_from_the_check_it_was_answered_from_runs_the_fast_stages_at_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A key answered from a check the text has since been edited in another place
    (20 declarations away) runs the fast stages at once: left to wait for a pause,
    every key of a typist who never pauses scanned the text between the two places
    again (at 20,805 lines, completion p50 61 to 68 ms where it was 22)."""
    from test_lsp_edges import _edit

    with _far_apart(tmp_path, monkeypatch) as watched:
        wire, uri = watched.wire, watched.uri
        wire.notify("textDocument/didChange", _edit(uri, 3, 21, _FAR, _FAR, "7"))
        found = wire.diagnostics_until(uri, lambda p: p["version"] == 3)
        assert found["diagnostics"] == []
        _until(lambda: watched.checked)
        edited = FAR_APART.replace("V > 0\n", "V > 70\n").replace("V > 19\n", "V > 719\n")
        assert watched.answered == [False, True]  # both answered, the far key far
        assert watched.checked == [edited]  # the near key's fast stages wait still


def test_a_far_key_overtaken_still_brings_the_check_up_to_date(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A far key a newer key overtook while the edit path worked it out runs the
    fast stages all the same, on the newest text: a typist asking for completion
    at each key overtook every far key before its fast stages began, and the check
    the edit path worked from stayed far behind for the whole run."""
    from test_lsp_edges import _edit

    with _far_apart(tmp_path, monkeypatch, hold="V > 719\n") as watched:
        wire, uri = watched.wire, watched.uri
        wire.notify("textDocument/didChange", _edit(uri, 3, 21, _FAR, _FAR, "7"))
        _until(watched.held.is_set)
        wire.notify("textDocument/didChange", _edit(uri, 4, 21, _FAR, _FAR + 1, ""))
        generation = wire.process.server.state.generation
        _until(lambda: max(generation.values()) == 4)
        watched.gate.set()  # the far key is worked out now, overtaken by the one erasing it
        found = wire.diagnostics_until(uri, lambda p: p["version"] == 4)
        assert found["diagnostics"] == []
        _until(lambda: watched.checked)
        assert watched.answered == [False, True, False]  # the erasing key is near again
        assert watched.checked == [FAR_APART.replace("V > 0\n", "V > 70\n")]


_BOTH = FAR_APART.replace("V > 0\n", "V > 70\n").replace("V > 19\n", "V > 719\n")


@contextlib.contextmanager
def _renewing(watched: _Watched) -> Iterator[threading.Event]:
    """A far key typed in E19 (version 3, making _BOTH), its fast stages run at
    once and held as they end, until the event yielded is set (on leaving too)."""
    from test_lsp_edges import _edit

    workspace = watched.wire.process.server.state.workspace
    counted, checking, renewed = workspace.check, threading.Event(), threading.Event()

    def held(path: str, *args: Any, **options: Any) -> Any:
        checked = counted(path, *args, **options)
        checking.set()
        renewed.wait(60)
        return checked

    workspace.check = held
    try:
        watched.wire.notify("textDocument/didChange", _edit(watched.uri, 3, 21, _FAR, _FAR, "7"))
        _until(checking.is_set)
        yield renewed
    finally:
        renewed.set()


def _until_renewed(state: Any) -> None:
    """Until the edit path works from the check of _BOTH."""
    _until(lambda: [r.model.sources.get(r.model.specs[0].path).text
                    for r in state.fast.values()] == [_BOTH])  # fmt: skip


def _answered_once_renewed(watched: _Watched, far: list[bool]) -> None:
    """Version 4 answered, after the fast stages of _BOTH ended and became the edit
    path's check; its answers far as `far` says; no other run of the fast stages."""
    state = watched.wire.process.server.state
    _until_renewed(state)
    found = watched.wire.diagnostics_until(watched.uri, lambda p: p["version"] == 4)
    assert found["diagnostics"] == []
    assert watched.answered == far
    time.sleep(0.3)  # a second run of the fast stages would have begun by now
    assert watched.checked == [_BOTH]


def test_a_key_queued_while_far_fast_stages_ran_is_answered_from_their_check(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A key that waited for the edit lane while a far key's fast stages ran is
    worked out from their check, finished meanwhile, not from the one it came to:
    answered from that, it was far again and ran the fast stages a second time
    (at 20,805 lines, 500 ms of them beside a completing typist's requests)."""
    from test_lsp_edges import _edit

    with _far_apart(tmp_path, monkeypatch) as watched:
        wire, uri = watched.wire, watched.uri
        state = wire.process.server.state
        lane_free = threading.Event()
        try:
            with _renewing(watched) as renewed:
                state.edit_lane.submit(lane_free.wait, 60)
                wire.notify("textDocument/didChange", _edit(uri, 4, 21, _FAR, _FAR, "8"))
                _until(lambda: max(state.generation.values()) == 4)
                renewed.set()  # the fast stages end while the key waits for the lane
                _until_renewed(state)
        finally:
            lane_free.set()
        _answered_once_renewed(watched, [False, True, False])  # the queued key: near


def test_a_far_key_worked_out_while_fast_stages_ended_does_not_run_them_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A far key worked out from the check that fast stages, ending meanwhile,
    replaced leaves them be: the next key is near their check. Run again, they
    held the interpreter from a completing typist's requests for 500 ms more (at
    20,805 lines)."""
    from test_lsp_edges import _edit

    with _far_apart(tmp_path, monkeypatch, hold="V > 8719\n") as watched:
        wire, uri = watched.wire, watched.uri
        with _renewing(watched) as renewed:
            wire.notify("textDocument/didChange", _edit(uri, 4, 21, _FAR, _FAR, "8"))
            _until(watched.held.is_set)  # its edit path at work on the check before
            renewed.set()
        state = wire.process.server.state
        _until_renewed(state)
        watched.gate.set()  # its answer comes after the fast stages ended
        _answered_once_renewed(watched, [False, True, True])  # from the check before


def test_fast_stages_overtaken_by_a_key_still_serve_the_edit_path(tmp_path: Path) -> None:
    """The fast stages of a text a newer key has changed are not published, but
    the edit path works out the next keys from them. Dropped, a typist quicker
    than the fast stages left the edit path an ever older text, whose edits it
    could not bridge, so every key waited for the fast stages (at 20,805 lines,
    a completing typist's keys: 250 ms each, and completion p99 110 ms)."""
    from test_lsp_edges import _edit

    text = SERVED + "event E when V > 100\nproperty P: always[<=1s] not E\n"
    with _served(tmp_path, text, lambda p: p["version"] == 1 and p["diagnostics"] == []) as (
        wire,
        uri,
    ):
        state = wire.process.server.state
        workspace = state.workspace
        entered: list[str] = []
        gates = {2: threading.Event(), 3: threading.Event()}
        real = workspace.check

        def held(path: str, *args: Any, **options: Any) -> Any:
            entered.append(workspace.documents()[path])
            gate = gates.get(len(entered))
            if gate is not None:
                gate.wait(60)
            return real(path, *args, **options)

        def until(condition: Any) -> None:
            deadline = time.monotonic() + 20
            while not condition() and time.monotonic() < deadline:
                time.sleep(0.01)
            assert condition()

        workspace.check = held
        try:
            entered.append(text)  # the first check (not through `held`)
            topic = 'topic U: std_msgs/Float64 = "/u"\n'  # the edit path leaves topics
            wire.notify("textDocument/didChange", _edit(uri, 2, 0, 0, 0, topic))
            until(lambda: len(entered) == 2)  # the fast stages of version 2, held
            start = len("event E when V > ")
            wire.notify("textDocument/didChange", _edit(uri, 3, 3, start, start, "1"))
            until(lambda: state.generation.get(next(iter(state.generation))) == 3)
            gates[2].set()
            until(lambda: len(entered) == 3)  # version 2's done; version 3's held
            wire.notify("textDocument/didChange", _edit(uri, 4, 3, start, start, "2"))
            found = wire.diagnostics_until(uri, lambda p: p["version"] == 4, timeout=20)
            assert [d["code"] for d in found["diagnostics"]] == ["RMV203"]  # `U`, unused
            assert len(entered) == 3  # answered while version 3's fast stages ran
        finally:
            for gate in gates.values():
                gate.set()


def test_a_key_after_the_solver_stages_sends_the_fast_stages_of_its_text(tmp_path: Path) -> None:
    """The newest result holds the solver stages' findings of the text before the
    key; the key's first diagnostics are the fast stages' of its own text (the
    solver's come again after the pause), never the old text's findings moved."""
    from test_lsp_edges import _edit

    text = SERVED + "event E when V > 100\nproperty P: always[<=1s] (E and not E)\n"
    with _served(tmp_path, text, lambda p: p["diagnostics"]) as (wire, uri):
        solved = wire.diagnostics_until(uri, lambda p: p["diagnostics"])
        assert [d["code"] for d in solved["diagnostics"]] == ["RMV510"]
        start = len("event E when V > 10")
        wire.notify("textDocument/didChange", _edit(uri, 2, 2, start, start, "7"))
        first = wire.diagnostics_until(uri, lambda p: p["version"] == 2)
        assert first["diagnostics"] == []


def test_a_fault_of_the_edit_path_costs_the_key_nothing(tmp_path: Path, monkeypatch) -> None:
    """Should the edit path fail, the key's diagnostics come from the fast stages,
    and the editor's log says what failed."""
    from test_lsp_edges import _edit

    import rmvdsl.editor.workspace as workspace

    def broken(*_: object) -> None:
        raise ValueError("broken on purpose")

    monkeypatch.setattr(workspace, "check_edit", broken)
    text = SERVED + "event E when V > 100\nproperty P: always[<=1s] not E\n"
    with _served(tmp_path, text) as (wire, uri):
        start = len("event E when ")
        wire.notify("textDocument/didChange", _edit(uri, 2, 2, start, start + 1, "Q"))
        found = wire.diagnostics_until(uri, lambda p: p["version"] == 2)
        assert {d["code"] for d in found["diagnostics"]} == {"RMV200", "RMV203"}
        logged = [
            m["params"]["message"] for m in wire.seen if m.get("method") == "window/logMessage"
        ]
        assert any("broken on purpose" in message for message in logged)
