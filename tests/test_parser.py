"""Parsing: the tree, its spans, error recovery and the words of syntax errors."""

from __future__ import annotations

import bisect
import itertools
import re

import pytest
from conftest import EXAMPLES
from hypothesis import example, given, settings
from hypothesis import strategies as st
from lark.exceptions import UnexpectedInput

from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.grammar.parser import parse_source
from rmvdsl.grammar.scanner import (
    TOP_LEVEL_KEYWORDS,
    RawComment,
    ScanResult,
    _starts_declaration,
    chunk_before,
    rescan,
    scan,
)
from rmvdsl.grammar.shift import shifted
from rmvdsl.lang.source import SourceFile


def parse(text: str) -> tuple[ast.Spec, list]:
    result = parse_source(SourceFile("t.rmv", text))
    return result.spec, result.diagnostics


def test_every_name_span_covers_its_text():
    source = SourceFile("abs.rmv", (EXAMPLES / "carla" / "abs.rmv").read_text(encoding="utf-8"))
    spec = parse_source(source).spec
    idents = [n for n in ast.walk(spec) if isinstance(n, ast.Ident)]
    assert len(idents) > 150
    for ident in idents:
        assert source.text[ident.span.start : ident.span.end] == ident.name
    for decl in spec.items:
        assert source.text[decl.span.start :].split()[0] in TOP_LEVEL_KEYWORDS


def test_declaration_span_includes_closing_brace():
    text = "transducer T {\n    states A\n    initial A\n}\n"
    spec, _ = parse(text)
    assert text[spec.items[0].span.start : spec.items[0].span.end].endswith("}")


def test_formula_spans_point_into_the_latex_string():
    text = 'property P: latex "\\int^{10} HardBraking < 4"\n'
    spec, diagnostics = parse(text)
    assert diagnostics == []
    prop = next(n for n in fm.walk(spec.items[0].formula) if isinstance(n, fm.Prop))
    assert text[prop.span.start : prop.span.end] == "HardBraking"


def test_latex_escapes_map_spans_exactly():
    # `\\` in the .rmv string is one backslash of the formula.
    text = 'property P: latex "a \\\\lor Braking"\n'
    spec, diagnostics = parse(text)
    assert diagnostics == []
    prop = fm.propositions(spec.items[0].formula)[1]
    assert text[prop.span.start : prop.span.end] == "Braking"


def test_doc_comments_attach_to_the_next_declaration():
    spec, _ = parse(
        '/// The speed.\n/// In m/s.\nvar V = t.v\n\n/// Detached.\n\ntopic t: a/B = "/t"\n'
    )
    assert spec.items[0].doc == "The speed.\nIn m/s."
    assert spec.items[1].doc == ""


def test_both_message_type_forms():
    spec, diagnostics = parse('topic a: pkg/Type = "/a"\ntopic b: pkg/msg/Type = "/b"\n')
    assert diagnostics == []
    assert [t.msg_type.text for t in spec.items] == ["pkg/Type", "pkg/msg/Type"]


def test_field_paths_with_indices_and_aggregates():
    spec, diagnostics = parse(
        "var A = o.objects[3].pose.position.x\nvar B = max(o.objects[*].twist.linear.x)\n"
    )
    assert diagnostics == []
    first, second = spec.items
    assert first.source.text == "objects[3].pose.position.x"
    assert second.aggregate.name == "max" and second.source.segments[0].index == "*"


def test_event_clauses():
    spec, diagnostics = parse(
        "event E = derivative(mean(V), 1s) * 3.6 where V > 10 and not V = 3\n"
        '    group by time(100ms, 10ms), "car" fill linear order desc limit 1\n'
        "    resample every 1m for 2m range 1s\n"
    )
    assert diagnostics == []
    event = spec.items[0]
    assert [c.kind for c in event.clauses] == [
        "where",
        "group",
        "fill",
        "order",
        "limit",
        "resample",
        "range",
    ]
    group = event.clause("group").value
    assert group.interval.time.text == "100ms" and group.offset.time.text == "10ms"
    assert event.clause("resample").value.for_.time.text == "2m"


def test_operator_precedence_in_expressions():
    spec, _ = parse("event E when a + b * c > 2 or not d < 1 and e = 1\n")
    expr = spec.items[0].expr
    assert expr.op == "or"
    assert expr.left.op == ">" and expr.left.left.op == "+" and expr.left.left.right.op == "*"
    assert expr.right.op == "and" and expr.right.left.op == "not"


def test_formula_precedence():
    spec, _ = parse("property P: a -> b until[<10s] c and not d or eventually[=5s] e\n")
    f = spec.items[0].formula
    assert isinstance(f, fm.Binary) and f.op == "->"
    assert f.right.op == "or"
    assert f.right.left.op == "and" and f.right.left.left.op == "until"


def test_infix_and_latex_build_the_same_tree():
    spec, diagnostics = parse(
        "property A: (H -> (L or H) until[<10] S) and duration[10](H) < 4\n"
        'property B: latex "(H \\rightarrow ((L \\lor H) \\until{<10} S))'
        ' \\land \\int^{10} H < 4"\n'
    )
    assert diagnostics == []
    assert spec.items[0].formula == spec.items[1].formula


def test_recovery_reports_one_error_per_broken_declaration():
    text = (EXAMPLES / "errors" / "syntax.rmv").read_text(encoding="utf-8")
    spec, diagnostics = parse(text)
    assert [d.code for d in diagnostics] == ["RMV100", "RMV103", "RMV101", "RMV102", "RMV103"]
    # Declarations after the errors are still there.
    assert any(isinstance(i, ast.PropertyDecl) for i in spec.items)


def test_missing_closer_is_inserted_and_parse_goes_on():
    spec, diagnostics = parse("event E = mean(V * 2 group by time(1s)\n")
    assert len(diagnostics) == 1 and "insert `)`" in diagnostics[0].help
    assert spec.items[0].clause("group") is not None


def test_missing_brace_at_end_keeps_the_declaration():
    spec, diagnostics = parse("transducer T {\n    states A, B\n    initial A\n    A -> B on E\n")
    assert [d.code for d in diagnostics] == ["RMV103"]
    assert spec.items[0].transitions[0].dest.name == "B"


def test_unindented_keyword_ends_an_unclosed_block():
    spec, diagnostics = parse("alert A {\n    warn when X > 1\nvar X = t.x\n")
    assert [type(i).__name__ for i in spec.items] == ["AlertDecl", "VarDecl"]
    assert [d.code for d in diagnostics] == ["RMV103"]


@pytest.mark.parametrize(
    "text",
    [
        "var = t.x\n",
        "event E when\n",
        'topic t: a = "/t"\n',
        "property P: a until[<] b\n",
        "transducer T { states A,, B }\n",
        "alert A { info when }\n",
        "whitelist t { publishers: }\n",
    ],
)
def test_expected_tokens_are_words_not_terminal_names(text):
    _, diagnostics = parse(text)
    assert diagnostics
    for diagnostic in diagnostics:
        assert not re.search(
            r"__ANON|\bLPAR\b|\bRPAR\b|\bNAME\b|\bQUANTITY\b|\$END|KW_", diagnostic.message
        )


def test_keywords_are_names_where_a_name_is_expected():
    spec, diagnostics = parse('topic topic: std_msgs/String = "/t"\nvar event = topic.data\n')
    assert diagnostics == []
    assert spec.items[1].name.name == "event"


def test_strings_keep_backslashes_but_unescape_quotes():
    spec, _ = parse('alert A { warn when x > 1 message "say \\"hi\\" \\\\ \\n" }\n')
    assert spec.items[0].message.value == 'say "hi" \\ \\n'


def test_spans_start_at_the_operator_keyword():
    """A node led by a keyword (`not`, `eventually`, `duration`, unary `-`) spans it:
    the editor and the underlines of diagnostics point at the whole node."""
    from rmvdsl.grammar.formula_parser import parse_formula

    for text in ("eventually[<5s] a", "not a", "once[<=2s] historically[=1s] a"):
        node, _ = parse_formula(text, "rmv", "<f>", "formula")
        assert text[node.span.start : node.span.end] == text
    text = "duration[5s](a) > 1s"
    node, _ = parse_formula(text, "rmv", "<f>", "formula")
    assert text[node.left.span.start : node.left.span.end] == "duration[5s](a)"
    text = "event A when not V > 1 and -V < 2\n"
    parsed = parse_source(SourceFile("x.rmv", text))
    expression = parsed.spec.items[0].expr
    assert text[expression.left.span.start : expression.left.span.end] == "not V > 1"
    minus = expression.right.left
    assert text[minus.span.start : minus.span.end] == "-V"


# ---- the scanner against a character-by-character reading ----


def _reference_scan(text: str) -> ScanResult:
    """The scanner's rules read one character at a time, line by line: the
    readable definition the one-regex scan must agree with."""
    comments: list[RawComment] = []
    chunks = [(0, 1)]
    depth, offset = 0, 0
    for number, line in enumerate(text.split("\n"), 1):
        if _starts_declaration(line, depth):
            depth = 0
            if offset != chunks[-1][0]:
                chunks.append((offset, number))
        index = 0
        while index < len(line):
            char = line[index]
            if char == '"':
                index += 1
                while index < len(line) and line[index] != '"':
                    index += 2 if line[index] == "\\" else 1
            elif line.startswith("//", index):
                found = line[index:].rstrip("\r")
                start = offset + index
                comments.append(
                    RawComment(start, start + len(found), found, not line[:index].strip())
                )
                break
            elif char in "{([":
                depth += 1
            elif char in "})]":
                depth = max(0, depth - 1)
            index += 1
        offset += len(line) + 1
    return ScanResult(tuple(comments), tuple(chunks))


_SCAN_PIECES = [
    "topic", "time unit s", "time(100ms)", "timeunit", "event", "eventé", "  var", "\tnode",
    "property", "{", "}", "(", ")", "[", "]", '"', '\\"', "\\", "//", "/// doc", "/", "\n",
    "\n", "\r\n", " ", "x", "é", "_", "1", "transducer T {", "    states A", "import",
]  # fmt: skip


@settings(max_examples=400, deadline=None)
@given(st.lists(st.sampled_from(_SCAN_PIECES), max_size=40))
def test_scan_agrees_with_a_character_reading(pieces: list[str]) -> None:
    text = "".join(pieces)
    assert scan(text) == _reference_scan(text)


# A text of scan pieces, and the same with some of them replaced: (before, after).
_EDITED = st.tuples(
    st.lists(st.sampled_from(_SCAN_PIECES), max_size=40),
    st.integers(0, 40),
    st.integers(0, 3),
    st.lists(st.sampled_from(_SCAN_PIECES), max_size=3),
).map(lambda e: ("".join(e[0]), "".join(e[0][: e[1]] + e[3] + e[0][e[1] + e[2] :])))


@settings(max_examples=600, deadline=None)
@given(_EDITED)
def test_a_scan_after_an_edit_equals_a_fresh_one(edited: tuple[str, str]) -> None:
    """An editor's scan reuses the scan of the text before the edit: the chunks
    before it, and those of the unchanged end, moved."""
    before, after = edited
    assert scan(after, (before, scan(before))) == scan(after)


@settings(max_examples=600, deadline=None)
@given(_EDITED)
def test_the_chunk_before_an_offset_after_an_edit_is_a_fresh_scan_s(
    edited: tuple[str, str],
) -> None:
    """Completion's chunk, from the scan of the text before the edit, nothing of
    it moved: at every offset, the chunk a fresh scan of the new text finds."""
    before, after = edited
    chunks = scan(after).chunks
    old = scan(before)
    for offset in range(len(after) + 1):
        index = bisect.bisect_left(chunks, (offset,))
        expected = chunks[index - 1][0] if index else 0
        assert chunk_before(after, before, old, offset) == expected, offset


def _in_places(drawn: tuple[list[str], list[tuple[int, int, list[str]]]]) -> tuple[str, str]:
    """The text of `pieces` and the same with each (at, removed, added) edit made."""
    pieces, edits = drawn
    edited = list(pieces)
    for at, removed, added in sorted(edits, reverse=True):  # the last first: places hold
        edited[at : at + removed] = added
    return "".join(pieces), "".join(edited)


_PIECE = st.sampled_from(_SCAN_PIECES)
# A text of lines, most opening a declaration (a chunk each; some alike), the rest
# scan pieces, and the same edited in up to four places: (before, after).
_LINE = st.tuples(
    st.sampled_from(
        ["event E", "event E", "event", "var V", "  x", "time unit", "}", "property P: ("]
    ),
    st.lists(st.sampled_from([*_SCAN_PIECES[:-5], " x", " 1"]), max_size=4),
).map(lambda line: [line[0], *line[1], "\n"])
_EDITED_IN_PLACES = st.tuples(
    st.lists(_LINE, min_size=4, max_size=60).map(lambda lines: list(itertools.chain(*lines))),
    st.lists(
        st.tuples(st.integers(0, 300), st.integers(0, 3), st.lists(_PIECE, max_size=3)),
        max_size=4,
    ),
).map(_in_places)


_EVENTS = "".join(f"event E{k} when x > {k}\n" for k in range(20))


@pytest.mark.parametrize("patience", [1, 8])
@settings(max_examples=500, deadline=None)
@given(_EDITED_IN_PLACES)
# The second difference at the end of a keyword's line, which it makes a word (the
# line no longer starts a chunk): with the newline, and at the end of the text.
@example((_EVENTS + "event\nvar V\n", _EVENTS.replace("x > 3", "x > 37") + "eventx\nvar V\n"))
@example((_EVENTS + "time unit", _EVENTS.replace("x > 3", "x > 37") + "time unitx"))
def test_a_rescan_of_edits_in_several_places_finds_a_fresh_scan_s_chunks(
    patience: int, edited: tuple[str, str]
) -> None:
    """Rescan's chunks (the text between two edits skipped, its old chunks moved,
    after `patience` chunks scanned) are those of a fresh scan: the old ones before
    `first`, its own, and the old ones from `rest` on, moved by the edits."""
    from unittest import mock

    from rmvdsl.grammar import moved

    before, after = edited
    fresh, old = scan(after).chunks, scan(before)
    with mock.patch.object(moved, "PATIENCE", patience):
        found = rescan(after, before, old)
    assert fresh[: found.first] == old.chunks[: found.first]
    end = found.first + len(found.chunks)
    assert fresh[found.first : end] == found.chunks
    if found.rest is None:
        assert end == len(fresh)
    else:
        delta, lines = len(after) - len(before), after.count("\n") - before.count("\n")
        moved = tuple((at + delta, line + lines) for at, line in old.chunks[found.rest :])
        assert fresh[end:] == moved


def test_rescans_from_two_scans_in_turn_find_a_fresh_scan_s_chunks() -> None:
    """An editor rescans from two scans in turn (the edit path from its check's,
    completion from the newest parse's), each keeping the old chunks by their
    first line: whichever it rescans from, its chunks are a fresh scan's."""
    from rmvdsl.grammar import moved

    first = _EVENTS * 3
    second = first.replace("x > 1\n", "x > 12\n", 1)
    scans = {text: scan(text) for text in (first, second)}
    built = None
    for key in range(6):
        old = (first, second)[key % 2]
        edited = old.replace("x > 2\n", f"x > 2{key}\n", 1).replace("x > 18\n", "x > 189\n")
        found = rescan(edited, old, scans[old])
        fresh = scan(edited).chunks
        assert found.chunks == fresh[found.first : found.first + len(found.chunks)], key
        if key >= 1:  # both kept, and made once each
            kept = {text: id(by_line) for text, by_line in moved._KEPT}
            assert built in (None, kept) and set(kept) == {first, second}
            built = kept


def test_a_scan_after_an_edit_equals_a_fresh_one_on_the_examples() -> None:
    for path in sorted(EXAMPLES.rglob("*.rmv")):
        text = path.read_text(encoding="utf-8", errors="replace")
        for at in range(0, len(text), max(1, len(text) // 40)):
            for edit in ("", "x", "\n", "}", "{", '"', "//", "\nevent E when x\n"):
                after = text[:at] + edit + text[at + (len(edit) % 2) :]
                assert scan(after, (text, scan(text))) == scan(after), (path, at, edit)


def test_scan_agrees_on_the_examples() -> None:
    for path in sorted(EXAMPLES.rglob("*.rmv")):
        text = path.read_text(encoding="utf-8", errors="replace")
        assert scan(text) == _reference_scan(text), path


def test_a_formula_on_its_own_is_parsed_as_a_property_body_is():
    """`rmv eval` and `rmv sat` parse with the formula rule alone: the same tree as a
    property's body in a spec, and a mistake is told what a formula may hold there,
    never "a new declaration"."""
    from rmvdsl.grammar.formula_parser import parse_formula

    text = "historically ((once[<=10] q) -> ((not p) since q)) and duration[10s](H) < 4s"
    alone, diagnostics = parse_formula(text, "rmv", "x.rmv", "formula")
    prefix = "property P: "
    in_spec = parse_source(SourceFile("x.rmv", prefix + text + "\n")).spec.items[0].body.formula
    assert not diagnostics and shifted(alone, len(prefix)) == in_spec
    _, (mistake,) = parse_formula("a until b c", "rmv", "<f>", "formula")
    assert mistake.code == "RMV100" and "declaration" not in mistake.message
    assert "`until`" in mistake.message and mistake.span.start == 10


def _both_ways(text: str) -> list[tuple[object, object]]:
    """Each chunk of `text` parsed without recovery (where it has no error) and with
    recovery: declarations (spans included) and the builder's findings."""
    from rmvdsl.grammar.grammars import spec_parser
    from rmvdsl.grammar.recovery import ChunkParser
    from rmvdsl.grammar.scanner import scan
    from rmvdsl.grammar.unbroken import NotUnbroken, parse_unbroken

    _, builder = spec_parser()
    builder.start_parse("spec.rmv")
    source = SourceFile("spec.rmv", text)
    bounds = [*scan(text, None).chunks, (len(text), 0)]
    compared = []
    for (start, line), (end, _) in itertools.pairwise(bounds):
        before = len(builder.diagnostics)
        recovering = ChunkParser(source, start, end, line)
        slow = recovering._recovering()
        slow_found = builder.diagnostics[before:]
        del builder.diagnostics[before:]
        try:
            result, last = parse_unbroken(text, start, end, line)
        except (NotUnbroken, UnexpectedInput):
            del builder.diagnostics[before:]
            assert recovering.diagnostics or slow is None, text[start:end]  # an error, found
            continue
        fast = ChunkParser._closed(list(result) if result is not None else [], last)
        assert not recovering.diagnostics, text[start:end]
        compared.append(((fast, builder.diagnostics[before:]), (slow, slow_found)))
        del builder.diagnostics[before:]
    return compared


EXAMPLE_SPECS = [
    p.read_text(encoding="utf-8") for p in sorted(EXAMPLES.rglob("*.rmv")) if p.name != "latin1.rmv"
]


def test_a_chunk_without_errors_parses_alike_without_recovery():
    """rmvdsl.grammar.unbroken lexes with lark's own patterns and drives lark's own
    LALR table: every declaration of the examples, with its spans and the builder's
    findings, is what the recovering parser builds."""
    pairs = [pair for text in EXAMPLE_SPECS for pair in _both_ways(text)]
    assert len(pairs) > 300
    for fast, slow in pairs:
        assert fast == slow


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(EXAMPLE_SPECS), st.data())
def test_edited_chunks_parse_alike_or_go_to_recovery(text, data):
    """Random edits (deleted runs, stray characters and keywords, lines cut): a chunk
    the fast loop accepts is parsed alike by recovery, with no error there; one
    it refuses has an error recovery reports."""
    for _ in range(data.draw(st.integers(1, 4))):
        position = data.draw(st.integers(0, max(0, len(text) - 1)))
        snippet = data.draw(
            st.sampled_from(
                ["", "{", "}", "(", '"', "->", "state ", "\n", "é", "1e400", "10Hz", "@"]
            )
        )
        cut = data.draw(st.integers(0, 8))
        text = text[:position] + snippet + text[position + cut :]
    for fast, slow in _both_ways(text):
        assert fast == slow


@pytest.mark.parametrize("broken", ["_built", "_rows"])
def test_a_lark_whose_insides_differ_is_parsed_by_recovery_alike(monkeypatch, broken):
    """rmvdsl.grammar.unbroken reads lark's lexer and LALR table: where they are not
    as it knows them (a TypeError, as a changed lark would give), every chunk goes
    to the recovering parser, and the spec reads the same."""
    from rmvdsl.grammar import parser, unbroken

    text = EXAMPLE_SPECS[0]
    expected = parse(text)
    parser._CHUNK_CACHE.clear()
    monkeypatch.setattr(unbroken, "_COMPILED", [])

    def changed(*_: object) -> None:
        raise TypeError("not lark's as known")

    monkeypatch.setattr(unbroken, broken, changed)
    with pytest.raises(unbroken.NotUnbroken):
        unbroken.parse_unbroken(text, 0, len(text), 1)
    assert parse(text) == expected
    parser._CHUNK_CACHE.clear()
