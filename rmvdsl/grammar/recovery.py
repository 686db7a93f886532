"""Parsing one chunk of a spec with error recovery: lark's interactive parser fed token
by token, unexpected characters skipped, a missing closer inserted, and at most a few
diagnostics before the parser finds its feet again."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

from lark import Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken
from lark.lexer import LexerState, LineCounter
from lark.utils import TextSlice

from rmvdsl.grammar import ast
from rmvdsl.grammar.grammars import (
    describe_expected,
    describe_token,
    recognizer,
    spec_parser,
)
from rmvdsl.grammar.scanner import TOP_LEVEL_KEYWORDS
from rmvdsl.grammar.unbroken import NotUnbroken, parse_unbroken
from rmvdsl.lang.diagnostics import Diagnostic, Label, error
from rmvdsl.lang.source import SourceFile, Span
from rmvdsl.runtime.wording import counted

_CLOSERS = {"RPAR": ")", "RSQB": "]", "RBRACE": "}"}


_ACCEPTED_BEFORE_NEXT_REPORT = 3
MAX_ERRORS = 20  # in one declaration; then its rest is skipped


class ChunkParser:
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
        """The chunk's declarations. Most chunks have no error: they are parsed
        without recovery's bookkeeping (rmvdsl.grammar.unbroken); the first error
        starts the chunk again with recovery, the builder's findings of the
        failed attempt dropped."""
        _, builder = spec_parser()
        before = len(builder.diagnostics)
        try:
            result, last = parse_unbroken(self.source.text, self.start, self.end, self.line)
        except (NotUnbroken, UnexpectedInput):
            del builder.diagnostics[before:]
            return self._recovering()
        return self._closed(list(result) if result is not None else [], last)

    def _interactive(self) -> Any:
        parser, _ = spec_parser()
        interactive = parser.parse_interactive("", start="start")
        counter = LineCounter("\n")
        counter.char_pos = counter.line_start_pos = self.start
        counter.line = self.line
        interactive.lexer_thread.state = LexerState(
            TextSlice(self.source.text, self.start, self.end), counter
        )
        return interactive

    def _recovering(self) -> list[ast.Decl] | None:
        interactive = self._interactive()
        last: Token | None = None
        for token in self._tokens(interactive):
            if len(self.diagnostics) >= MAX_ERRORS:
                self._give_up(token)
                return None
            self._feed(interactive, token)
            last = token
        return self._closed(self._finish(interactive, last), last)

    @staticmethod
    def _closed(decls: list[ast.Decl] | None, last: Token | None) -> list[ast.Decl] | None:
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
        stop = stray_end(text, position, self.end)
        self._report(stray_error(text[position:stop], self.source.span(position, stop)), force=True)
        state.line_ctr.feed(text[position:stop])

    def _give_up(self, token: Token) -> None:
        """Too many errors in one declaration (not a spec, or a paste gone wrong): one
        error says where reading stopped, and the rest of the declaration is skipped."""
        last_line = self.source.position(max(self.start, self.end - 1)).line
        self.diagnostics.append(error(
            "RMV100",
            f"more than {counted(MAX_ERRORS, 'error')} in this declaration: the rest of it, "
            "to line "
            f"{last_line}, is not read",
            self.source.span(token.start_pos or self.start, token.end_pos or self.start),
            label="reading stopped here",
            help="is this file a spec? fix the errors above and check again",
        ))  # fmt: skip

    def _feed(self, interactive: Any, token: Token) -> None:
        try:
            interactive.feed_token(token)
            self.accepted += 1
            self.fed.append(token)
            return
        except UnexpectedToken:
            pass
        if self.accepted < _ACCEPTED_BEFORE_NEXT_REPORT:
            # Not reported (too close to the last error): recover without asking the
            # parser what it expected, which replays the whole declaration.
            closer = self._insertable_closer(interactive, token, set(_CLOSERS))
        else:
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
        trial = recognizer().parse_interactive("", start="start")
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
        elif str(token) == "=" and self._follows_equals(token):
            hint = "conditions are InfluxQL, which compares with one `=`: write `x = 5`"
        return error(
            "RMV100",
            f"expected {describe_expected(expected)}, found {describe_token(token)}",
            span,
            label="unexpected here",
            help=hint,
        )

    def _follows_equals(self, token: Token) -> bool:
        """Whether `token` is the second `=` of `==`."""
        before = self.fed[-1] if self.fed else None
        return before is not None and str(before) == "=" and before.end_pos == token.start_pos

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


# What can start a token of the language besides letters, digits and `_`.
_TOKEN_STARTS = frozenset('"!%&()*+,-./:<=>[]^{|}~')


def _stray(char: str) -> bool:
    return not (char.isspace() or (char.isascii() and (char.isalnum() or char == "_"))
                or char in _TOKEN_STARTS)  # fmt: skip


def stray_end(text: str, start: int, end: int) -> int:
    """Where a run of characters no token starts with ends: a word holding a letter
    outside ASCII (a name in another script) is one run, as are `$$$` or 500 NULs."""
    stop = start
    if text[start].isalpha():
        while stop < end and (text[stop].isalnum() or text[stop] == "_"):
            stop += 1
        return stop
    while stop < end and _stray(text[stop]) and not text[stop].isalpha():
        stop += 1
    return max(stop, start + 1)


def stray_error(run: str, span: Any) -> Diagnostic:
    """One error for a run of characters that start no token (RMV101)."""
    if run[0].isalpha():
        return error(
            "RMV101", f"`{run}` is not a name: names are ASCII letters, digits and `_`",
            span, label="a letter outside ASCII",
            help="write the name in ASCII letters (a ROS field keeps its own spelling: "
                 "only the spec's names are ASCII)",
        )  # fmt: skip
    shown = run if len(run) <= 8 else f"{run[:3]}…{run[-3:]}"
    count = f" ({counted(len(run), 'character', grouped=True)})" if shown != run else ""
    return error(
        "RMV101",
        f"unexpected character{'s' if len(run) > 1 else ''} `{shown}`{count}",
        span,
        label="no token of the language starts with "
        + ("these characters" if len(run) > 1 else "this character"),
        help="comments start with `//`; strings are written in double quotes",
    )
