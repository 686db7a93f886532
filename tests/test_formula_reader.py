"""The lark-free formula reader (rmvdsl.grammar.formula_reader) against lark's parser
with the formula builder: whatever it reads, lark reads alike, spans included; and
it reads every well-formed formula (or declines, and lark reads it: `rmv eval` then
gives lark's words for what is wrong)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from fractions import Fraction
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rmvdsl.grammar.formula_parser import parse_formula, parse_with_lark
from rmvdsl.grammar.formula_reader import read_formula
from rmvdsl.util.deep import deep

PATH = "<formula>"
NAMES = ["p", "q", "r", "_x", "p1", "nota", "trueish", "onceq", "topic", "event", "Until"]
CLEAN_UNITS = ["", "s", "ms", "us", "u", "ns", "m", "h", "d", "w"]
ODD_UNITS = ["Hz", "kHz", "e", "E", "xyz"]
NUMBERS = ["0", "3", "10", "0.5", ".25", "2.", "1e3", "1.5e-2", "007", "12345678"]
ODD_NUMBERS = ["1" + "0" * 120, "1e99999"]
KEYWORDS = ["and", "or", "not", "until", "since", "eventually", "always", "once",
            "historically", "duration", "true", "false"]  # fmt: skip
SYMBOLS = ["->", "<->", "(", ")", "[", "]", "<", "<=", ">", ">=", "==", "!=", "=", "+", "-", "*"]
CLEAN_GAPS = [" ", "  ", "\n", "\t", " // a comment\n"]


def shape(node: Any) -> Any:
    """A node as nested tuples, spans included (a formula's equality leaves them out)."""
    if dataclasses.is_dataclass(node) and not isinstance(node, type):
        fields = dataclasses.fields(node)
        return (type(node).__name__, *(shape(getattr(node, f.name)) for f in fields))
    if isinstance(node, list | tuple):
        return tuple(shape(item) for item in node)
    assert node is None or isinstance(node, str | bool | int | Fraction), node
    return node


def both(text: str, kind: str = "formula") -> tuple[Any, Any]:
    """The reader's node and lark's (None where lark reports a problem)."""
    read = read_formula(text, PATH, kind)
    node, problems = parse_with_lark(text, PATH, kind)
    return read, (None if problems else node)


def agree(text: str, kind: str = "formula") -> bool:
    """Whatever the reader reads, lark reads alike. True when the reader read it."""
    read, parsed = both(text, kind)
    if read is None:
        return False
    assert parsed is not None, f"the reader took {text!r}, lark did not"
    assert shape(read) == shape(parsed), text
    return True


# ---- formulas as token lists: (tokens, level), loosest level 0 -------------------
# formula 0 (`->`, `<->`); or 1; and 2; until/since 3; prefixes 4; atoms 5.
# terms: + and - 0; * 1; atoms 2 (terms have no parentheses).


@st.composite
def quantity(draw: Any, clean: bool) -> str:
    number = draw(st.sampled_from(NUMBERS if clean else NUMBERS + ODD_NUMBERS))
    return number + draw(st.sampled_from(CLEAN_UNITS if clean else CLEAN_UNITS + ODD_UNITS))


@st.composite
def bound(draw: Any, clean: bool) -> list[str]:
    if not draw(st.booleans()):
        return []
    return ["[", draw(st.sampled_from(["<", "<=", "="])), draw(quantity(clean)), "]"]


@st.composite
def term(draw: Any, level: int, depth: int, clean: bool) -> list[str]:
    choice = draw(st.integers(0, 4 if depth > 0 else 1))
    if choice == 3 and level == 0:
        operator = draw(st.sampled_from(["+", "-"]))
        left = draw(term(0, depth - 1, clean))
        return [*left, operator, *draw(term(1, depth - 1, clean))]
    if choice == 4 and level <= 1:
        return [*draw(term(1, depth - 1, clean)), "*", *draw(term(2, depth - 1, clean))]
    if choice == 2 and depth > 0:
        window = draw(quantity(clean))
        return ["duration", "[", window, "]", "(", *draw(formula(0, depth - 1, clean)), ")"]
    return ["-", draw(quantity(clean))] if choice == 1 else [draw(quantity(clean))]


@st.composite
def formula(draw: Any, level: int, depth: int, clean: bool) -> list[str]:
    made, made_level = draw(_formula(depth, clean))
    if made_level < level or (depth > 0 and draw(st.integers(0, 9)) == 0):
        return ["(", *made, ")"]
    return made


@st.composite
def _formula(draw: Any, depth: int, clean: bool) -> tuple[list[str], int]:
    choice = draw(st.integers(0, 9 if depth > 0 else 2))
    below = depth - 1
    if choice == 0:
        names = NAMES if clean else NAMES + KEYWORDS
        return [draw(st.sampled_from(names))], 5
    if choice == 1:
        return [draw(st.sampled_from(["true", "false"]))], 5
    if choice == 2:
        comparison = draw(st.sampled_from(["<", "<=", ">", ">=", "==", "!="]))
        return [*draw(term(0, max(below, 0), clean)), comparison,
                *draw(term(0, max(below, 0), clean))], 5  # fmt: skip
    if choice == 3:
        return ["not", *draw(formula(4, below, clean))], 4
    if choice == 4:
        operator = draw(st.sampled_from(["eventually", "always", "once", "historically"]))
        return [operator, *draw(bound(clean)), *draw(formula(4, below, clean))], 4
    if choice == 5:
        operator = draw(st.sampled_from(["until", "since"]))
        left, right = draw(formula(4, below, clean)), draw(formula(4, below, clean))
        return [*left, operator, *draw(bound(clean)), *right], 3
    if choice == 6:
        return [*draw(formula(2, below, clean)), "and", *draw(formula(3, below, clean))], 2
    if choice == 7:
        return [*draw(formula(1, below, clean)), "or", *draw(formula(2, below, clean))], 1
    if choice == 8:
        return [*draw(formula(1, below, clean)), "->", *draw(formula(0, below, clean))], 0
    return [*draw(formula(1, below, clean)), "<->", *draw(formula(1, below, clean))], 0


@st.composite
def written(draw: Any, tokens: list[str], clean: bool) -> str:
    gaps = CLEAN_GAPS if clean else ["", *CLEAN_GAPS]
    text = draw(st.sampled_from(["", " ", "\n"]))
    for token in tokens:
        text += token + draw(st.sampled_from(gaps))
    return text


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_reads_every_well_formed_formula_as_lark_does(data: Any) -> None:
    tokens = data.draw(formula(0, 4, clean=True))
    text = data.draw(written(tokens, clean=True))
    assert agree(text), f"declined a well-formed formula: {text!r}"


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_reads_every_well_formed_term_as_lark_does(data: Any) -> None:
    tokens = data.draw(term(0, 3, clean=True))
    assert agree(data.draw(written(tokens, clean=True)), "term")


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_odd_formulas_are_read_as_lark_does_or_left_to_it(data: Any) -> None:
    """Keywords for names, units to report, numbers out of range, tokens glued."""
    tokens = data.draw(formula(0, 4, clean=False))
    agree(data.draw(written(tokens, clean=False)))


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_token_strings_are_read_as_lark_does_or_left_to_it(data: Any) -> None:
    """Random strings of the grammar's tokens: mostly errors, which the reader leaves
    to lark; any it reads, lark reads alike."""
    vocabulary = NAMES[:3] + KEYWORDS + SYMBOLS + ["3", "2s", "1.5ms", "4Hz", "#", "é"]
    tokens = data.draw(st.lists(st.sampled_from(vocabulary), max_size=12))
    text = data.draw(written(tokens, clean=False))
    agree(text)
    agree(text, "term")


@pytest.mark.parametrize(
    "text",
    [
        "historically ((r and not q and once q)"
        " -> (historically[<3] p and once[=3] (p since[<=7] q)))",
        "(HardBraking -> (AntiLockBrake or HardBraking) until[<10s] Stopped)"
        " and duration[10s](HardBraking) < 4s",
        "a -> b -> c -> d",
        "a or b and c or d",
        "not once[<=3] p until[<2ms] eventually q",
        "3 < -2",
        "3<-2",
        "1 - -2 * 3 + duration[5](p) >= 0.5u",
        "p // a comment\n and q",
    ],
)
def test_examples_read_alike(text: str) -> None:
    assert agree(text)


@pytest.mark.parametrize(
    ("text", "lark_reads_it"),
    [
        ("until and p", True),  # lark's contextual lexer reads `until` as a name there
        ("p and and", True),
        ("p until q until r", False),
        ("a <-> b <-> c", False),
        ("(3 + 4) < 5", False),
        ("once[<2Hz] p", True),  # reported by the builder
        ("duration[1xyz](p) < 1", True),
        ("p and", False),
        ("", False),
    ],
)
def test_left_to_lark(text: str, lark_reads_it: bool) -> None:
    assert read_formula(text, PATH) is None
    assert (parse_with_lark(text, PATH)[0] is not None) is lark_reads_it
    assert parse_formula(text, path=PATH) == parse_with_lark(text, PATH)


def _same_as_lark(text: str) -> bool:
    node, problems = parse_formula(text, path=PATH)
    return not problems and node == parse_with_lark(text, PATH)[0]


def test_deep_nesting() -> None:
    """On the commands' deep stack (rmvdsl.util.deep) the reader takes 20,000 nested
    levels; past the recursion limit it declines, and lark's parser reads the text."""
    text = "not (" * 20_000 + "p" + ")" * 20_000
    assert deep(read_formula, text, PATH) is not None
    assert deep(_same_as_lark, text)
    shallow = "not " * 5_000 + "p"
    assert read_formula(shallow, PATH) is None  # the default limit: 1,000 calls
    assert deep(_same_as_lark, shallow)


LOADED = (
    "import sys\n"
    "from rmvdsl.cli import main\n"
    "code = main(['eval', '--formula', sys.argv[1], '--trace', sys.argv[2]])\n"
    "print(code, 'lark' in sys.modules)\n"
)


@pytest.mark.parametrize(
    ("formula", "expected"),
    [("once[<=3] p and not q", "0 False"), ("once[<=3] p and", "1 True")],
)
def test_eval_loads_lark_only_to_explain(tmp_path: Any, formula: str, expected: str) -> None:
    """`rmv eval` of a well-formed formula never imports lark (the point of the
    reader: its start); of a malformed one, lark's parser says what is wrong."""
    trace = tmp_path / "t.jsonl"
    trace.write_text('{"t": 0, "state": "p"}\n{"t": 1, "end": true}\n', encoding="utf-8")
    command = [sys.executable, "-c", LOADED, formula, str(trace)]
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    assert result.stdout.splitlines()[-1] == expected, result.stderr
    if expected.endswith("True"):
        assert "expected a name" in result.stderr  # lark's words: what would fit there
