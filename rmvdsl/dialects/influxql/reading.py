"""Reading InfluxQL: its tokens, and a parser for the statements `rmv deploy`
reads (our own `influxdb.iql`, edited or not, and the queries SHOW prints)."""

from __future__ import annotations

from collections.abc import Iterator

from rmvdsl.dialects.common import (
    Cursor,
    Lexicon,
    Token,
    climb,
    nesting_refused,
    quoted_end,
    scan,
)
from rmvdsl.dialects.influxql.syntax import (
    NS_PER_UNIT,
    Call,
    CreateContinuousQuery,
    CreateDatabase,
    CreateRetentionPolicy,
    Expr,
    InfluxQLError,
    Literal,
    Measurement,
    Name,
    Other,
    Select,
    Statement,
    Text,
    Unary,
    unquote,
)

# ---- tokens ----

KEYWORDS = frozenset(
    ("ALL", "ALTER", "AND", "AS", "ASC", "BEGIN", "BY", "CONTINUOUS", "CREATE", "DATABASE",
     "DEFAULT", "DESC", "DROP", "DURATION", "END", "EVERY", "FALSE", "FILL", "FOR", "FROM",
     "GROUP", "INTO", "LIMIT", "NOT", "ON", "OR", "ORDER", "POLICY", "QUERY", "REPLICATION",
     "RESAMPLE", "RETENTION", "SELECT", "SHARD", "TRUE", "WHERE")
)  # fmt: skip


def _quoted(text: str, start: int) -> tuple[str, int]:
    kind = "ident" if text[start] == '"' else "string"
    return kind, quoted_end(text, start, InfluxQLError)


def _number(text: str, start: int) -> tuple[str, int]:
    index = start
    while index < len(text) and (text[index].isdigit() or text[index] == "."):
        index += 1
    unit_end = index
    while unit_end < len(text) and (text[unit_end].isalpha() or text[unit_end] == "µ"):
        unit_end += 1
    if unit_end > index and text[index:unit_end] in NS_PER_UNIT:
        return "duration", unit_end
    return "number", index


LEXICON = Lexicon(
    comment="--", quoted=_quoted, number=_number,
    word=lambda word: "keyword" if word.upper() in KEYWORDS else "ident",
    operators=("!=", "<>", "<=", ">=", "=~", "!~", "=", "<", ">", "+", "-", "*", "/", "%",
               "&", "|", "^"),
    punctuation="(),;.:", error=InfluxQLError,
)  # fmt: skip


def tokens(text: str) -> Iterator[Token]:
    """The tokens of an InfluxQL text; whitespace and `--` comments skipped."""
    return scan(text, LEXICON)


def value(token: Token) -> str:
    """An identifier's or a string's meaning; a keyword upper-cased."""
    return token.text.upper() if token.kind == "keyword" else unquote(token.text)


# ---- the parser ----


class _Reader(Cursor):
    def __init__(self, text: str) -> None:
        super().__init__(list(tokens(text)), InfluxQLError, "statement", fold=True)
        self.text = text

    def name(self) -> str:
        token = self.next("a name")
        if token.kind != "ident":
            raise InfluxQLError(f"expected a name, found `{token.text}` at offset {token.start}")
        return value(token)

    def word(self, kinds: tuple[str, ...], what: str) -> str:
        token = self.next(what)
        if token.kind not in kinds:
            raise InfluxQLError(f"expected {what}, found `{token.text}` at offset {token.start}")
        return token.text


_BINDING = (("OR",), ("AND",), ("=", "!=", "<>", "<", "<=", ">", ">=", "=~", "!~"),
            ("+", "-", "|", "^"), ("*", "/", "%", "&"))  # fmt: skip


def _expression(reader: _Reader) -> Expr:
    result: Expr = climb(reader, _BINDING, lambda: _primary(reader))
    return result


def _primary(reader: _Reader) -> Expr:
    token = reader.next("an expression")
    if token.text == "(":
        inner = _expression(reader)
        reader.expect(")")
        return inner
    if token.text == "-":
        return Unary("-", _primary(reader))
    if token.kind == "string":
        return Text(value(token))
    if token.kind in ("number", "duration") or token.text.upper() in ("TRUE", "FALSE"):
        return Literal(token.text)
    if token.kind == "ident" and reader.take("("):
        args: list[Expr] = []
        while not reader.take(")"):
            if args:
                reader.expect(",")
            args.append(_expression(reader))
        return Call(token.text, tuple(args))
    if token.kind == "ident" or token.text == "*":
        return Name(value(token))
    raise reader.unexpected(token)


def _measurement(reader: _Reader) -> Measurement:
    parts = [reader.name()]
    while reader.take("."):
        parts.append(reader.name())
    if len(parts) != 3:
        raise InfluxQLError("expected a measurement written database.retention.name")
    return Measurement(*parts)


def _select(reader: _Reader) -> Select:
    reader.expect("SELECT")
    columns = []
    while True:
        expr = _expression(reader)
        reader.expect("AS")
        columns.append((expr, reader.name()))
        if not reader.take(","):
            break
    reader.expect("INTO")
    into = _measurement(reader)
    reader.expect("FROM")
    source = _measurement(reader)
    where = _expression(reader) if reader.take("WHERE") else None
    reader.expect("GROUP", "BY")
    reader.expect("TIME", "(")
    interval = reader.word(("duration",), "a duration")
    offset = reader.word(("duration",), "a duration") if reader.take(",") else None
    reader.expect(")")
    every_tag = reader.take(",", "*")
    fill = None
    if reader.take("FILL", "("):
        words = []
        while not reader.take(")"):
            words.append(reader.next("`)`").text)
        fill = "".join(words)
    descending = reader.take("ORDER", "BY", "TIME", "DESC")
    reader.take("ORDER", "BY", "TIME", "ASC")
    limit = int(reader.word(("number",), "a number")) if reader.take("LIMIT") else None
    return Select(tuple(columns), into, source, where, interval, offset, every_tag, fill,
                  descending, limit)  # fmt: skip


def _body(reader: _Reader) -> Select | str:
    """A continuous query's SELECT, through its END: as a tree, or as written when
    it holds what this module does not model (a hand-edited query)."""
    start = reader.index
    try:
        select = _select(reader)
        reader.expect("END")
        return select
    except InfluxQLError as why:
        reader.index = start
        return _as_written(reader, why)


def _as_written(reader: _Reader, why: InfluxQLError) -> str:
    """The tokens from here to the statement's last END, as written (with no END:
    the error that made it needed)."""
    start = reader.index
    ends = [i for i in range(start + 1, len(reader.items)) if reader.items[i].text.upper() == "END"]
    if not ends:
        raise why
    first, last = reader.items[start], reader.items[ends[-1] - 1]
    reader.index = ends[-1] + 1
    return reader.text[first.start : last.start + len(last.text)]


@nesting_refused(InfluxQLError)
def _statement(text: str) -> Statement:
    reader = _Reader(text)
    if reader.take("CREATE", "DATABASE"):
        stmt: Statement = CreateDatabase(reader.name())
    elif reader.take("CREATE", "RETENTION", "POLICY"):
        name = reader.name()
        reader.expect("ON")
        database = reader.name()
        reader.expect("DURATION")
        length = reader.word(("duration", "ident"), "a duration")
        reader.expect("REPLICATION")
        replication = int(reader.word(("number",), "a number"))
        shard = None
        if reader.take("SHARD", "DURATION"):
            shard = reader.word(("duration",), "a duration")
        stmt = CreateRetentionPolicy(name, database, length, replication, shard,
                                     reader.take("DEFAULT"))  # fmt: skip
    elif reader.take("CREATE", "CONTINUOUS", "QUERY"):
        name = reader.name()
        reader.expect("ON")
        database = reader.name()
        every = for_ = None
        if reader.take("RESAMPLE"):
            every = reader.word(("duration",), "a duration") if reader.take("EVERY") else None
            for_ = reader.word(("duration",), "a duration") if reader.take("FOR") else None
        reader.expect("BEGIN")
        stmt = CreateContinuousQuery(name, database, every, for_, _body(reader))
    else:
        return Other(text)
    if (extra := reader.peek()) is not None:
        raise InfluxQLError(f"unexpected `{extra.text}` at offset {extra.start}")
    return stmt


def split(text: str) -> list[str]:
    """The statements of a text, split at the `;`s between tokens, comments left out."""
    found: list[list[Token]] = [[]]
    for token in tokens(text):
        if token.text == ";" and token.kind == "punct":
            found.append([])
        else:
            found[-1].append(token)
    return [text[group[0].start : group[-1].start + len(group[-1].text)]
            for group in found if group]  # fmt: skip


def parse(text: str) -> list[Statement]:
    """Every statement of a text: those the kapacitor target writes as trees, any
    other as written (`Other`). InfluxQLError names what is malformed."""
    return [_statement(piece) for piece in split(text)]


def parse_query(shown: str) -> CreateContinuousQuery:
    """A continuous query as SHOW CONTINUOUS QUERIES prints it."""
    stmt = _statement(shown)
    if not isinstance(stmt, CreateContinuousQuery):
        raise InfluxQLError(f"not a continuous query: {shown[:80]}")
    return stmt
