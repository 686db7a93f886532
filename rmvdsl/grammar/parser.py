"""Parsing .rmv text into the AST, recovering from errors.

Recovery works on two levels. The scanner cuts the file into top-level
declarations and each is parsed on its own, so one broken declaration never hides
the next. Inside a declaration, the LALR parser is driven token by token: a
missing `)`, `]` or `}` is inserted when that lets the parse go on, otherwise the
offending token is skipped; a new error is reported only after three tokens were
accepted since the previous one, so one mistake gives one message.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from importlib import resources
from typing import Any, cast

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken
from lark.lexer import LexerState, LineCounter, PatternStr
from lark.utils import TextSlice

from rmvdsl.grammar import ast
from rmvdsl.grammar.builder import AstBuilder
from rmvdsl.grammar.formula import Formula
from rmvdsl.grammar.scanner import TOP_LEVEL_KEYWORDS, RawComment, ScanResult, scan
from rmvdsl.grammar.shift import shifted, with_field
from rmvdsl.lang.diagnostics import Diagnostic, Label, did_you_mean, error
from rmvdsl.lang.source import SourceFile, Span
from rmvdsl.util.bounded import Bounded

_SPEC_GRAMMAR_FILES = ("rmv.lark", "expr.lark", "formula.lark", "lexical.lark")
_CLOSERS = {"RPAR": ")", "RSQB": "]", "RBRACE": "}"}
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_ACCEPTED_BEFORE_NEXT_REPORT = 3

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


@functools.cache
def _spec_parser() -> tuple[Lark, AstBuilder]:
    builder = AstBuilder()
    parser = Lark(
        _grammar_text(_SPEC_GRAMMAR_FILES),
        parser="lalr",
        lexer="contextual",
        start=["start", "formula", "term"],
        transformer=builder,
        maybe_placeholders=True,
        # The LALR tables are kept in the temporary folder, keyed by the grammar's
        # hash: every later run starts about 0.2 s sooner.
        cache=True,
    )
    return parser, builder


@functools.cache
def _latex_parser() -> tuple[Lark, AstBuilder]:
    builder = AstBuilder()
    parser = Lark(
        _grammar_text(("latex.lark",)),
        parser="lalr",
        lexer="contextual",
        start=["start", "term"],
        transformer=builder,
        maybe_placeholders=True,
        cache=True,
    )
    return parser, builder


@functools.cache
def _recognizer() -> Lark:
    """The spec grammar with no actions: replays token streams to ask what fits."""
    return bare_spec_parser()


def bare_spec_parser() -> Lark:
    """lark alone on the same grammar, building its own parse tree (the benchmark's
    baseline)."""
    return Lark(
        _grammar_text(_SPEC_GRAMMAR_FILES),
        parser="lalr",
        lexer="contextual",
        start=["start", "formula", "term"],
        maybe_placeholders=True,
    )


@functools.cache
def _terminal_texts(which: str) -> dict[str, str]:
    parser = _spec_parser()[0] if which == "spec" else _latex_parser()[0]
    texts = dict(_FRIENDLY) if which == "spec" else {**_FRIENDLY, **_LATEX_FRIENDLY}
    for terminal in parser.terminals:
        if terminal.name in texts:
            continue
        if isinstance(terminal.pattern, PatternStr):
            texts[terminal.name] = f"`{terminal.pattern.value}`"
    return texts


def keywords() -> frozenset[str]:
    """Every word the grammar reserves somewhere (the editor will complete them)."""
    parser, _ = _spec_parser()
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
    parser = _recognizer()
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


@functools.cache
def reserved_names() -> frozenset[str]:
    """Words that cannot stand for a name inside an expression or a formula (`and`,
    `true`, `always`, ...): a declaration named so could never be referred to."""
    text = _grammar_text(("expr.lark", "formula.lark", "lexical.lark"))
    return frozenset(re.findall(r'"([a-z_]+)"', text)) & keywords()


def describe_expected(expected: set[str] | frozenset[str], which: str = "spec") -> str:
    texts = _terminal_texts(which)
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


@dataclass
class ParsedSpec:
    spec: ast.Spec
    diagnostics: list[Diagnostic]
    # Identifiers of declarations that had syntax errors: names that may have been
    # lost, so that "undefined name" is not reported for them.
    damaged_names: set[str] = field(default_factory=set)
    # Offsets [start, end) of the declarations that had syntax errors.
    damaged_ranges: list[tuple[int, int]] = field(default_factory=list)


class _ChunkParser:
    """Parses one declaration chunk with token-level recovery."""

    def __init__(self, source: SourceFile, start: int, end: int, line: int) -> None:
        self.source = source
        self.start = start
        self.end = end
        self.line = line
        self.diagnostics: list[Diagnostic] = []
        self.accepted = _ACCEPTED_BEFORE_NEXT_REPORT
        self.fed: list[Token] = []  # the tokens the parser took, in order

    def parse(self) -> list[ast.Decl] | None:
        parser, _ = _spec_parser()
        interactive = parser.parse_interactive("", start="start")
        counter = LineCounter("\n")
        counter.char_pos = counter.line_start_pos = self.start
        counter.line = self.line
        interactive.lexer_thread.state = LexerState(
            TextSlice(self.source.text, self.start, self.end), counter
        )
        last: Token | None = None
        for token in self._tokens(interactive):
            self._feed(interactive, token)
            last = token
        decls = self._finish(interactive, last)
        if decls and len(decls) == 1 and last is not None and last.end_pos is not None:
            # A declaration's span runs to its last token, the closing `}` included.
            decl = decls[0]
            end = Span(decl.span.path, decl.span.start, last.end_pos)
            decls[0] = dataclasses.replace(decl, span=decl.span.cover(end))  # type: ignore[call-arg]
        return decls

    def _tokens(self, interactive: Any) -> Iterator[Token]:
        while True:
            stream = interactive.lexer_thread.lex(interactive.parser_state)
            try:
                yield from stream
                return
            except UnexpectedCharacters as exc:
                self._skip_characters(interactive, exc)
            except UnexpectedToken as exc:
                # The contextual lexer found a token valid elsewhere in the grammar.
                yield exc.token

    def _skip_characters(self, interactive: Any, exc: UnexpectedCharacters) -> None:
        state = interactive.lexer_thread.state
        position = state.line_ctr.char_pos
        text = self.source.text
        if text[position] == '"':
            line_end = text.find("\n", position)
            line_end = self.end if line_end == -1 or line_end > self.end else line_end
            self._report(
                error(
                    "RMV102",
                    "unterminated string",
                    self.source.span(position, line_end),
                    label='this string has no closing `"`',
                    help='close the string on the same line; write \\" for a quote inside it',
                ),
                force=True,
            )
            state.line_ctr.feed(text[position:line_end])
            return
        char = text[position]
        self._report(
            error(
                "RMV101",
                f"unexpected character `{char}`",
                self.source.span(position, position + 1),
                label="no token of the language starts with this character",
                help="comments start with `//`; strings are written in double quotes",
            ),
            force=True,
        )
        state.line_ctr.feed(char)

    def _feed(self, interactive: Any, token: Token) -> None:
        try:
            interactive.feed_token(token)
            self.accepted += 1
            self.fed.append(token)
            return
        except UnexpectedToken:
            expected = self._expected_before()
        closer = self._insertable_closer(interactive, token, expected)
        self._report(self._unexpected(token, expected, closer))
        self.accepted = 0
        if closer is not None:
            inserted = Token.new_borrow_pos(closer, _CLOSERS[closer], token)
            interactive.feed_token(inserted)
            interactive.feed_token(token)
            self.fed += [inserted, token]

    def _expected_before(self) -> set[str]:
        """What the parser would have taken instead of the token it refused. A refused
        token may already have made the parser reduce (LALR lookahead sets are merged
        across contexts: after `when X`, a name reduces the expression), so the tokens
        taken so far are replayed on a parser without actions and asked there;
        accepts() tries each token, so the answer is exact."""
        trial = _recognizer().parse_interactive("", start="start")
        for taken in self.fed:
            trial.feed_token(taken)
        return set(trial.accepts())

    def _insertable_closer(self, interactive: Any, token: Token, expected: set[str]) -> str | None:
        for closer in _CLOSERS:
            if closer not in expected:
                continue
            trial = interactive.copy(deepcopy_values=False)
            try:
                trial.feed_token(Token.new_borrow_pos(closer, _CLOSERS[closer], token))
                trial.feed_token(token)
            except UnexpectedInput:
                continue
            return closer
        return None

    def _unexpected(self, token: Token, expected: set[str], closer: str | None) -> Diagnostic:
        span = self.source.span(token.start_pos or 0, token.end_pos or 0)
        hint = None
        if closer is not None:
            hint = f"insert `{_CLOSERS[closer]}` before {describe_token(token)}"
        elif token.type == "NAME" and str(token) in TOP_LEVEL_KEYWORDS:
            hint = "start each declaration on a line of its own, without indentation"
        return error(
            "RMV100",
            f"expected {describe_expected(expected)}, found {describe_token(token)}",
            span,
            label="unexpected here",
            help=hint,
        )

    def _finish(self, interactive: Any, last: Token | None) -> list[ast.Decl] | None:
        reported_eof = False
        for _ in range(64):
            try:
                result = interactive.feed_eof(last)
                return list(result) if result is not None else []
            except UnexpectedToken:
                expected = set(interactive.accepts())
            closer = next((c for c in _CLOSERS if c in expected), None)
            if not reported_eof and (self.accepted > 0 or not self.diagnostics):
                self._report_eof(expected, last, closer)
                reported_eof = True
            if closer is None or last is None:
                return None
            interactive.feed_token(Token.new_borrow_pos(closer, _CLOSERS[closer], last))
        return None

    def _report_eof(self, expected: set[str], last: Token | None, closer: str | None) -> None:
        end = self.end
        while end > self.start and self.source.text[end - 1].isspace():
            end -= 1
        position = last.end_pos if last is not None and last.end_pos is not None else end
        opener = _last_unclosed(self.source.text, self.start, self.end)
        secondary = []
        if opener is not None:
            secondary.append(Label(self.source.span(opener, opener + 1), "opened here"))
        self._report(
            error(
                "RMV103",
                f"unexpected end of declaration: expected {describe_expected(expected)}",
                self.source.span(position, position),
                label="the declaration ends here",
                secondary=secondary,
                help=f"insert `{_CLOSERS[closer]}`" if closer else None,
            ),
            force=True,
        )

    def _report(self, diagnostic: Diagnostic, force: bool = False) -> None:
        if force or self.accepted >= _ACCEPTED_BEFORE_NEXT_REPORT:
            self.diagnostics.append(diagnostic)
        if force:
            self.accepted = 0


def _last_unclosed(text: str, start: int, end: int) -> int | None:
    stack: list[int] = []
    index = start
    while index < end:
        char = text[index]
        if char == '"':
            index += 1
            while index < end and text[index] not in '"\n':
                index += 2 if text[index] == "\\" else 1
        elif char == "/" and text.startswith("//", index):
            newline = text.find("\n", index)
            index = end if newline == -1 else newline
        elif char in "{([":
            stack.append(index)
        elif char in "})]" and stack:
            stack.pop()
        index += 1
    return stack[-1] if stack else None


@dataclass(frozen=True)
class _Chunk:
    """One declaration chunk's parse, as parsed at `start`."""

    start: int
    decls: tuple[ast.Decl, ...] | None
    diagnostics: tuple[Diagnostic, ...]  # the chunk's own and the builder's
    damaged: bool


# An editor re-parses a file at every keystroke; most of its declarations have not
# changed. Chunks are kept by their file and text (a bounded cache) and reused with
# their spans moved to where the chunk now starts. The bound grows to twice the
# chunks of the largest file parsed: a file larger than the cache would otherwise
# evict its own chunks on every parse (a 159,000-line spec was parsed from scratch
# each time, 1.5 times lark's bare parse).
_CHUNK_CACHE_SIZE = 50_000
_CHUNK_CACHE: Bounded[tuple[str, str], _Chunk] = Bounded(_CHUNK_CACHE_SIZE)


def _parsed_chunk(
    source: SourceFile, start: int, end: int, line: int, builder: AstBuilder
) -> _Chunk:
    key = (source.path, source.text[start:end])
    cached = _CHUNK_CACHE.get(key)
    if cached is None:
        before = len(builder.diagnostics)
        parser = _ChunkParser(source, start, end, line)
        decls = parser.parse()
        damaged = bool(parser.diagnostics) or decls is None
        latex: list[Diagnostic] = []
        if decls is not None:
            decls, latex = _parse_latex_bodies(decls)
        found = (*parser.diagnostics, *builder.diagnostics[before:], *latex)
        cached = _Chunk(start, None if decls is None else tuple(decls), found, damaged)
        _CHUNK_CACHE.put(key, cached)
    delta = start - cached.start
    if delta == 0:
        return cached
    return _Chunk(start, shifted(cached.decls, delta), shifted(cached.diagnostics, delta),
                  cached.damaged)  # fmt: skip


# The last text parsed of each file (the most recent files) and its scan: the next
# parse of the file scans only what an edit changed.
_LAST_SCANS: Bounded[str, tuple[str, ScanResult]] = Bounded(64)


def _scanned(source: SourceFile) -> ScanResult:
    scanned = scan(source.text, _LAST_SCANS.get(source.path))
    _LAST_SCANS.put(source.path, (source.text, scanned))
    return scanned


def parse_source(source: SourceFile) -> ParsedSpec:
    """Parse a whole file: every declaration, every syntax error."""
    _, builder = _spec_parser()
    builder.start_parse(source.path)
    scanned = _scanned(source)
    items: list[ast.Decl] = []
    diagnostics: list[Diagnostic] = []
    damaged: set[str] = set()
    ranges: list[tuple[int, int]] = []
    bounds = [*scanned.chunks, (len(source.text), 0)]
    _CHUNK_CACHE.fit(len(bounds))
    for (start, line), (end, _) in itertools.pairwise(bounds):
        chunk = _parsed_chunk(source, start, end, line, builder)
        if chunk.decls:
            items.extend(chunk.decls)
        diagnostics.extend(chunk.diagnostics)
        if chunk.damaged:
            damaged.update(_IDENTIFIER.findall(source.text, start, end))
            ranges.append((start, end))
    items = _attach_docs(items, scanned.comments, source)
    comments = tuple(ast.Comment(c.text, source.span(c.start, c.end)) for c in scanned.comments)
    spec = ast.Spec(source.path, tuple(items), comments, source.span(0, len(source.text)))
    return ParsedSpec(spec, _unique(diagnostics), damaged, ranges)


def _unique(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    return list(dict.fromkeys(diagnostics))


def _attach_docs(
    items: list[ast.Decl], comments: tuple[RawComment, ...], source: SourceFile
) -> list[ast.Decl]:
    doc_lines: dict[int, str] = {}
    for comment in comments:
        if comment.own_line and comment.text.startswith("///"):
            text = comment.text[3:]
            doc_lines[source.position(comment.start).line] = text[1:] if text[:1] == " " else text
    if not doc_lines:
        return items
    attached = []
    for item in items:
        line = source.position(item.span.start).line - 1
        lines = []
        while line in doc_lines:
            lines.append(doc_lines[line])
            line -= 1
        doc = "\n".join(reversed(lines))
        attached.append(with_field(item, "doc", doc) if doc else item)
    return attached


def _parse_latex_bodies(items: list[ast.Decl]) -> tuple[list[ast.Decl], list[Diagnostic]]:
    diagnostics: list[Diagnostic] = []
    result: list[ast.Decl] = []
    for item in items:
        if isinstance(item, ast.PropertyDecl) and isinstance(item.body, ast.LatexFormula):
            formula, found = parse_latex(item.body.source)
            diagnostics.extend(found)
            body = dataclasses.replace(item.body, formula=formula)
            item = dataclasses.replace(item, body=body)
        result.append(item)
    return result, diagnostics


def parse_latex(literal: ast.StringLit, start: str = "start") -> tuple[Any, list[Diagnostic]]:
    """Parse the LaTeX notation inside a string literal; spans point into the file."""
    parser, builder = _latex_parser()
    path = literal.span.path
    offsets = literal.offsets or tuple(range(literal.span.start + 1, literal.span.end - 1))
    value = literal.value

    def file_span(start: int, end: int) -> Span:
        if not offsets:
            return literal.span
        first = (
            offsets[min(start, len(offsets) - 1)] if start < len(offsets) else literal.span.end - 1
        )
        last = offsets[end - 1] + 1 if 0 < end <= len(offsets) else first
        return Span(path, first, max(first, last))

    builder.start_parse(path, lambda token: file_span(token.start_pos or 0, token.end_pos or 0))
    try:
        formula = parser.parse(value, start=start)
    except UnexpectedInput as exc:
        return None, [*builder.diagnostics, _latex_error(exc, value, file_span)]
    return cast(Formula, formula), list(builder.diagnostics)


def _latex_error(exc: UnexpectedInput, value: str, file_span: Any) -> Diagnostic:
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        start = token.start_pos if token.type != "$END" else len(value)
        end = token.end_pos if token.type != "$END" else len(value)
        found = "the end of the formula" if token.type == "$END" else f"`{token}`"
        message = f"expected {describe_expected(set(exc.expected), 'latex')}, found {found}"
    else:
        start = exc.pos_in_stream or 0
        end = start + 1
        command = re.match(r"\\[A-Za-z]+", value[start:])
        found = command.group(0) if command else value[start : start + 1]
        message = f"unknown command or character `{found}`"
        end = start + len(found)
        suggestion = did_you_mean(found, LATEX_COMMANDS) if command else None
        if suggestion:
            return error(
                "RMV104",
                f"in LaTeX formula: {message}",
                file_span(start, end),
                label="not a command of the notation",
                help=suggestion,
            )
    return error(
        "RMV104",
        f"in LaTeX formula: {message}",
        file_span(start or 0, end or 0),
        label="here",
        help="the notation is rmtld3synth's: see `rmv explain RMV104`",
    )


LATEX_COMMANDS = (
    "\\lor",
    "\\vee",
    "\\land",
    "\\wedge",
    "\\neg",
    "\\lnot",
    "\\not",
    "\\rightarrow",
    "\\implies",
    "\\leftrightarrow",
    "\\iff",
    "\\until",
    "\\since",
    "\\eventually",
    "\\always",
    "\\int",
    "\\top",
    "\\bot",
    "\\leq",
    "\\geq",
    "\\left",
    "\\right",
)


def parse_formula(
    text: str, syntax: str = "auto", path: str = "<formula>", kind: str = "formula"
) -> tuple[Any, list[Diagnostic]]:
    """Parse one formula (or, with kind="term", one term) given on its own."""
    if syntax == "auto":
        syntax = "latex" if "\\" in text else "rmv"
    if syntax == "latex":
        literal = ast.StringLit(text, Span(path, -1, len(text) + 1), tuple(range(len(text))))
        return parse_latex(literal, "start" if kind == "formula" else "term")
    parser, builder = _spec_parser()
    builder.start_parse(path)
    try:
        formula = parser.parse(text, start=kind)
    except UnexpectedToken as exc:
        token = exc.token
        position = token.start_pos if token.type != "$END" else len(text)
        found = "the end of the formula" if token.type == "$END" else f"`{token}`"
        return None, [
            error(
                "RMV100",
                f"expected {describe_expected(set(exc.expected))}, found {found}",
                Span(path, position or 0, token.end_pos or position or 0),
            )
        ]
    except UnexpectedCharacters as exc:
        position = exc.pos_in_stream or 0
        return None, [
            error(
                "RMV101",
                f"unexpected character `{text[position]}`",
                Span(path, position, position + 1),
            )
        ]
    return cast(Formula, formula), list(builder.diagnostics)
