"""`rmv fmt`: canonical, idempotent, meaning-preserving, comments kept."""

from __future__ import annotations

import pytest
from conftest import EXAMPLES

from rmvdsl.grammar.formatter import format_spec
from rmvdsl.grammar.parser import parse_source
from rmvdsl.lang.source import SourceFile

PARSEABLE = sorted(
    p
    for p in EXAMPLES.rglob("*.rmv")
    if p.name != "latin1.rmv"
    and not any(
        d.is_error
        for d in parse_source(
            SourceFile(str(p), p.read_bytes().decode("utf-8", "replace"))
        ).diagnostics
    )
)


def fmt(text: str) -> str:
    source = SourceFile("t.rmv", text)
    parsed = parse_source(source)
    assert not [d for d in parsed.diagnostics if d.is_error]
    return format_spec(parsed.spec, source)


def tree(text: str):
    return parse_source(SourceFile("t.rmv", text)).spec


def comments(text: str) -> list[str]:
    return [c.text.strip() for c in tree(text).comments]


@pytest.mark.parametrize("path", PARSEABLE, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_examples_format_idempotently_and_keep_meaning(path):
    text = path.read_text(encoding="utf-8")
    once = fmt(text)
    assert fmt(once) == once
    assert tree(once) == tree(text)
    assert comments(once) == comments(text)


def test_good_examples_are_already_formatted():
    for name in ("carla/abs.rmv", "gazebo/prius_platoon.rmv", "gazebo/network.rmv"):
        text = (EXAMPLES / name).read_text(encoding="utf-8")
        assert fmt(text) == text, name


def test_comments_stay_with_their_code():
    text = (
        "// header\n\n"
        "transducer T {  // the machine\n"
        "    // the states\n"
        "    states A, B\n"
        "    initial A  // start here\n"
        "    A -> B on E\n"
        "    // nothing after\n"
        "}\n"
        "// trailing\n"
    )
    assert fmt(text) == text


def test_parentheses_only_where_needed():
    text = "property P: ((a and (b)) or (c until[<1s] (d))) -> (not (e))\n"
    assert fmt(text) == "property P: a and b or c until[<1s] d -> not e\n"
    grouped = "event E when (a + b) * c > (d - e) - f\n"
    assert fmt(grouped) == "event E when (a + b) * c > d - e - f\n"
    right = "event E when a - (b - c) > 0\n"
    assert fmt(right) == right


def test_comparison_under_temporal_operator_keeps_parentheses():
    text = "property P: always[<=10s] (duration[10s](D) < 2s)\n"
    assert fmt(text) == text


def test_blank_lines_are_kept_single():
    text = "var A = t.a\n\n\n\nvar B = t.b\nvar C = t.c\n"
    assert fmt(text) == "var A = t.a\n\nvar B = t.b\nvar C = t.c\n"


def test_string_escapes_round_trip():
    text = 'alert A {\n    warn when x > 1\n    message "a \\"b\\" \\\\ \\c"\n}\n'
    once = fmt(text)
    assert tree(once) == tree(text)
    # Backslashes are escaped only where they would be read as an escape.
    assert 'message "a \\"b\\" \\ \\c"' in once
