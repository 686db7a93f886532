"""Completion reads only the declaration under the cursor, from the file's last scan
(an editor's: rmvdsl.grammar.parser.scan_file), and answers what a scan of the text
before the cursor and a walk back over all of it answered."""

from __future__ import annotations

import random
import re

import pytest
from conftest import EXAMPLES
from hypothesis import given, settings
from hypothesis import strategies as st

from rmvdsl.check import check
from rmvdsl.editor import completion, ranking
from rmvdsl.editor.completion import completions
from rmvdsl.grammar.scanner import scan

# Every example a user may open (one is Latin-1 on purpose: not text to complete in).
SPECS = sorted(p for p in EXAMPLES.rglob("*.rmv") if p.name != "latin1.rmv")


def _offsets(text: str, seed: str) -> list[int]:
    """Random places, and the ends of words that start lines (there a declaration
    begins at the word being completed)."""
    rng = random.Random(seed)
    found = rng.sample(range(len(text) + 1), min(60, len(text) + 1))
    return sorted(found) + [m.end() for m in re.finditer(r"^\w+", text, re.M)][:20]


@pytest.mark.parametrize("spec", SPECS, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_completion_from_the_last_scan_equals_a_fresh_one(spec):
    """Typing: each request comes after an edit (a word typed somewhere, or not),
    so the scan it reuses is of another text."""
    text = spec.read_text(encoding="utf-8")
    result = check(str(spec))
    rng = random.Random(spec.name)
    for offset in _offsets(text, spec.name):
        at = rng.randrange(len(text) + 1)
        edited = text if rng.random() < 0.3 else text[:at] + " x" + text[at:]
        where = offset + 2 if edited != text and at < offset else offset
        fresh = completions(result, edited, where)
        assert completions(result, edited, where, str(spec)) == fresh, (offset, at)


def _walked_block(before: str) -> str | None:
    """The enclosing block as completion first found it, walking back over every
    character before the cursor: the reference."""
    depth = 0
    for index in range(len(before) - 1, -1, -1):
        if before[index] == "}":
            depth += 1
        elif before[index] == "{":
            if depth == 0:
                line = before[before.rfind("\n", 0, index) + 1 : index]
                if re.search(r"\bqos\s*$", line):
                    return "qos"
                opener = re.match(r"^\s*(\w+)", line)
                return opener.group(1) if opener else None
            depth -= 1
    return None


@pytest.mark.parametrize("spec", SPECS, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_the_enclosing_block_is_found_within_the_declaration(spec):
    text = spec.read_text(encoding="utf-8")
    for offset in _offsets(text, spec.name):
        word = re.search(r"\w*\Z", text[:offset])
        start = word.start() if word else offset
        chunk = max((c for c, _ in scan(text[:start]).chunks if c < start), default=0)
        found = completion._enclosing_block(text[chunk:start])
        assert found == _walked_block(text[:start]), offset


# ---- what of a long list an editor is sent (rmvdsl.editor.ranking) ----


def test_a_short_list_is_sent_whole_for_the_editor_to_filter():
    labels = ["event", "var", "Speed", "mean"]
    assert ranking.shortlist(labels, labels, "Sp") == (labels, False)


def test_a_long_list_sends_the_best_matches_of_the_word_and_asks_to_be_asked_again():
    labels = ["event", "every", *(f"V{n}" for n in range(2000)), "average_V1"]
    sent, cut = ranking.shortlist(labels, labels, "V1")
    assert cut and len(sent) == ranking.LIMIT
    assert sent[:12] == ["V1", *(f"V1{d}" for d in range(10)), "V100"]
    assert "event" not in sent  # no V then 1 in it
    assert "average_V1" not in sent  # 1,111 names start with V1
    # lower case finds the names too, after any written as typed
    sent, _ = ranking.shortlist(labels, labels, "v1")
    assert sent[:2] == ["V1", "V10"]


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.text("aAbB_1", min_size=1, max_size=5), max_size=30),
    st.text("aAbB1", max_size=3),
    st.integers(1, 20),
)
def test_nothing_that_matches_better_is_left_out(labels, word, limit):
    sent, cut = ranking.shortlist(labels, labels, word, limit)
    if not cut:
        assert sent == labels
        return
    assert len(labels) > limit and len(sent) <= limit
    assert all(_in_order(word.lower(), s.lower()) for s in sent)
    matching = [label for label in labels if _in_order(word.lower(), label.lower())]
    if len(matching) <= limit:
        assert sorted(sent) == sorted(matching)
    # those starting with the word as typed come first, the shorter first
    starting = sorted((label for label in labels if label.startswith(word)), key=len)
    head = min(len(starting), limit)
    assert sent[:head] == starting[:head]
    # and all of it in the order of (not as typed, not in any case, length, index)
    wanted = word.lower()
    ranked = sorted(
        (not label.startswith(word), not label.lower().startswith(wanted), len(label), index)
        for index, label in enumerate(labels)
        if _in_order(wanted, label.lower())
    )
    assert sent == [labels[entry[3]] for entry in ranked[:limit]]


@pytest.mark.parametrize("spec", SPECS[:12], ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_what_is_sent_is_the_shortlist_of_every_completion(spec):
    """The server makes a name's completion only if it is sent: what it sends is
    what shortlisting every completion sends (a small limit, so lists are cut)."""
    text = spec.read_text(encoding="utf-8")
    result = check(str(spec))
    for offset in _offsets(text, spec.name):
        every = completions(result, text, offset)
        word = ranking.typed_word(text, offset)
        expected = ranking.shortlist(every, [c.label for c in every], word, 3)
        assert completion.sent_completions(result, text, offset, limit=3) == expected, offset


def _in_order(letters: str, label: str) -> bool:
    rest = iter(label)
    return all(letter in rest for letter in letters)


def test_the_typed_word_is_the_name_written_before_the_cursor():
    text = "event E when Sp\n  V1"
    assert ranking.typed_word(text, 15) == "Sp"
    assert ranking.typed_word(text, 16) == ""
    assert ranking.typed_word(text, len(text)) == "V1"


def test_the_names_completed_are_those_of_the_check_asked_with(tmp_path):
    """The names in scope and their labels are worked out once per check (not at
    each key): a check of another text, asked with in turn, has its own, and a
    check let go is not kept alive by them."""
    import gc
    import weakref

    spec = tmp_path / "names.rmv"
    head = 'topic T: std_msgs/Float64 = "/t"\nvar Speed = T.data\n'
    line = "event E when Sp"
    texts = [head + line, head + "var Spare = T.data\n" + line]
    results = [check(str(spec), text, solver=False) for text in texts]
    for _ in range(2):
        for result, text in zip(results, texts, strict=True):
            sent, _ = completion.sent_completions(result, text, len(text), limit=1)
            declared = {s.name for s in result.model.symbols.values() if s.kind.value == "variable"}
            every = completions(result, text, len(text))
            assert {c.label for c in every if c.kind == "variable"} == declared
            assert sent == ranking.shortlist(every, [c.label for c in every], "Sp", 1)[0]
    gone = weakref.ref(results[1].model)
    del results[1], result
    gc.collect()
    assert gone() is None
