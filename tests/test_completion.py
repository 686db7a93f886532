"""Completion reads only the declaration under the cursor, from the file's last scan
(an editor's: rmvdsl.grammar.parser.scan_file), and answers what a scan of the text
before the cursor and a walk back over all of it answered."""

from __future__ import annotations

import random
import re

import pytest
from conftest import EXAMPLES

from rmvdsl.check import check
from rmvdsl.editor import workspace
from rmvdsl.editor.workspace import completions
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
        found = workspace._enclosing_block(text[chunk:start])
        assert found == _walked_block(text[:start]), offset
