"""The lark parsers of the language (built once, shared by every thread) and the words
they accept: keywords, reserved names, and the wording of what a parser expected."""

from __future__ import annotations

import functools
import re
import threading
from collections.abc import Callable
from importlib import resources
from typing import TYPE_CHECKING, Any, TypeVar

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput
from lark.lexer import PatternStr

from rmvdsl.grammar.build_formulas import FormulaRules
from rmvdsl.grammar.scanner import TOP_LEVEL_KEYWORDS

if TYPE_CHECKING:  # the declarations' builder is loaded by the parsers that build them
    from rmvdsl.grammar.builder import AstBuilder

_SPEC_GRAMMAR_FILES = ("rmv.lark", "expr.lark", "formula.lark", "lexical.lark")
_Built = TypeVar("_Built")


def built_once(build: Callable[..., _Built]) -> Callable[..., _Built]:
    """functools.cache, whose first call builds while other threads asking at the
    same time wait for it: the editor's event loop and its lanes ask for the same
    parser at once, and each would otherwise build its own (a second or more of
    lark's table building, paid by whichever request came first)."""
    cached = functools.cache(build)
    lock = threading.Lock()

    @functools.wraps(build)
    def get(*args: Any) -> _Built:
        with lock:
            return cached(*args)

    return get


_FRIENDLY = {
    "NAME": "a name",
    "QUANTITY": "a number",
    "NUMBER": "a number",
    "STRING": "a string",
    "$END": "the end of the file",
    "END_OF_DECLARATION": "the end of the declaration",
}


# The LaTeX grammar's terminals share names with the infix grammar's (`AND` is
# `and` there): these texts apply to LaTeX messages only.
_LATEX_FRIENDLY = {
    "OR": "`\\lor`",
    "AND": "`\\land`",
    "NOT": "`\\neg`",
    "IMPLIES": "`\\rightarrow`",
    "IFF": "`\\leftrightarrow`",
    "UNTIL": "`\\until`",
    "SINCE": "`\\since`",
    "EVENTUALLY": "`\\eventually`",
    "ALWAYS": "`\\always`",
    "INT": "`\\int`",
    "TOP": "`\\top`",
    "BOT": "`\\bot`",
    "LE": "`<=`",
    "GE": "`>=`",
}


def _grammar_text(names: tuple[str, ...]) -> str:
    folder = resources.files("rmvdsl.grammar")
    return "\n".join(folder.joinpath(name).read_text(encoding="utf-8") for name in names)


def _building(files: tuple[str, ...], start: list[str], builder: Any) -> Lark:
    """An LALR parser of these grammar files that builds its result with `builder`
    as it parses (no parse tree is made). The tables are kept in the temporary
    folder, keyed by the grammar's hash and the options: every later run starts
    about 0.2 s sooner."""
    return Lark(
        _grammar_text(files),
        parser="lalr",
        lexer="contextual",
        start=start,
        transformer=builder,
        maybe_placeholders=True,
        cache=True,
    )


@built_once
def spec_parser() -> tuple[Lark, AstBuilder]:
    from rmvdsl.grammar.builder import AstBuilder

    builder = AstBuilder()
    return _building(_SPEC_GRAMMAR_FILES, ["start", "formula", "term"], builder), builder


@built_once
def formula_parser() -> tuple[Lark, FormulaRules]:
    """The spec grammar from `formula` and `term` only, building formulas alone: a
    formula given on its own (`rmv eval`, `rmv sat`) loads no declaration's rules and
    a sixth of the tables."""
    builder = FormulaRules()
    return _building(_SPEC_GRAMMAR_FILES, ["formula", "term"], builder), builder


@built_once
def latex_parser() -> tuple[Lark, AstBuilder]:
    from rmvdsl.grammar.builder import AstBuilder

    builder = AstBuilder()
    return _building(("latex.lark",), ["start", "term"], builder), builder


@built_once
def recognizer() -> Lark:
    """The spec grammar with no actions: replays token streams to ask what fits
    (completion, and the parser's recovery from a syntax error). Its tables are
    kept in the temporary folder, as the building parsers' are."""
    return bare_spec_parser(cache=True)


def bare_spec_parser(cache: bool = False) -> Lark:
    """lark alone on the same grammar, building its own parse tree (the benchmark's
    baseline)."""
    return Lark(
        _grammar_text(_SPEC_GRAMMAR_FILES),
        parser="lalr",
        lexer="contextual",
        start=["start", "formula", "term"],
        maybe_placeholders=True,
        cache=cache,
    )


@built_once
def terminal_texts(which: str) -> dict[str, str]:
    parser = spec_parser()[0] if which == "spec" else latex_parser()[0]
    texts = dict(_FRIENDLY) if which == "spec" else {**_FRIENDLY, **_LATEX_FRIENDLY}
    for terminal in parser.terminals:
        if terminal.name in texts:
            continue
        if isinstance(terminal.pattern, PatternStr):
            texts[terminal.name] = f"`{terminal.pattern.value}`"
    return texts


def keywords() -> frozenset[str]:
    """Every word the grammar reserves somewhere (the editor will complete them)."""
    parser, _ = spec_parser()
    return frozenset(
        terminal.pattern.value
        for terminal in parser.terminals
        if isinstance(terminal.pattern, PatternStr) and terminal.pattern.value.isidentifier()
    )


def accepted_words(text: str, start: int, offset: int) -> tuple[frozenset[str], bool] | None:
    """What the grammar accepts at `offset` of a declaration starting at `start`:
    its keywords, and whether a name may stand there. None when the text before
    `offset` has a syntax error (nothing can be said from the tables then). A
    declaration may also end there: the top-level words count as accepted then."""
    parser = recognizer()
    interactive = parser.parse_interactive(text[start:offset], start="start")
    try:
        interactive.exhaust_lexer()
    except (UnexpectedInput, UnexpectedCharacters):
        return None
    accepted = set(interactive.accepts())
    words = {
        terminal.pattern.value
        for terminal in parser.terminals
        if terminal.name in accepted
        and isinstance(terminal.pattern, PatternStr)
        and terminal.pattern.value.isidentifier()
    }
    if "$END" in accepted:
        words |= TOP_LEVEL_KEYWORDS
    return frozenset(words), "NAME" in accepted


@built_once
def reserved_names() -> frozenset[str]:
    """Words that cannot stand for a name inside an expression or a formula (`and`,
    `true`, `always`, ...): a declaration named so could never be referred to."""
    text = _grammar_text(("expr.lark", "formula.lark", "lexical.lark"))
    return frozenset(re.findall(r'"([a-z_]+)"', text)) & keywords()


def describe_expected(expected: set[str] | frozenset[str], which: str = "spec") -> str:
    texts = terminal_texts(which)
    keywords = sorted(name for name in expected if name.startswith("KW_") and name != "KW_COMPLETE")
    rest = [name for name in expected if name not in keywords]
    if which == "spec" and "$END" in rest:
        # Each declaration is parsed alone: its end is not the file's.
        rest.remove("$END")
        if not keywords:
            rest.append("END_OF_DECLARATION")
    words = sorted({texts.get(name, f"`{name.lower()}`") for name in rest}, key=_word_order)
    symbols = [w for w in words if w.startswith("`") and not any(c.isalpha() for c in w)]
    if len(symbols) > 5:  # after a value: every operator fits; name a few
        shown = [s for s in ("`+`", "`<`", "`=`") if s in symbols][:2]
        words = [w for w in words if w not in symbols]
        words.append(f"an operator ({', '.join([*shown, '...'])})")
    if len(keywords) >= 5:
        words.append("a new declaration (`topic`, `var`, `event`, ...)")
    else:
        words.extend(texts.get(name, name) for name in keywords)
    if len(words) > 12:
        words = [*words[:12], "..."]
    if not words:
        return "nothing more"
    if len(words) == 1:
        return words[0]
    return ", ".join(words[:-1]) + " or " + words[-1]


def _word_order(word: str) -> tuple[int, str]:
    return (0 if word.startswith("a ") else 1, word)


def describe_token(token: Token) -> str:
    if token.type == "$END":
        return "the end of the file"
    if token.type == "STRING":
        return f"the string {token}"
    return f"`{token}`"
