"""TICKscript (Kapacitor 1.x) as rmvdsl writes and reads it: pipelines and lambda
expressions as a small tree, the one quoting rule for each kind of literal (as
Kapacitor's lexer, tick/ast/lex.go, reads them), their printer, and a parser for
`rmv import` (the thesis's alert scripts)."""

from rmvdsl.dialects.tickscript.reading import BINDING, LEXICON, Token, parse, tokens, value
from rmvdsl.dialects.tickscript.syntax import (
    Binary,
    Call,
    Dbrp,
    Expr,
    Identifier,
    Lambda,
    Literal,
    Pipeline,
    Reference,
    Statement,
    Step,
    Text,
    TickError,
    Unary,
    Var,
    duration,
    expression,
    go_template_text,
    reference,
    statement,
    string,
)

__all__ = [
    "BINDING",
    "LEXICON",
    "Binary",
    "Call",
    "Dbrp",
    "Expr",
    "Identifier",
    "Lambda",
    "Literal",
    "Pipeline",
    "Reference",
    "Statement",
    "Step",
    "Text",
    "TickError",
    "Token",
    "Unary",
    "Var",
    "duration",
    "expression",
    "go_template_text",
    "parse",
    "reference",
    "statement",
    "string",
    "tokens",
    "value",
]
