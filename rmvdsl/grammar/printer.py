"""Printing AST pieces back as .rmv text, with the fewest parentheses that keep
the tree the same. The formatter and `rmv import` both print through here."""

from __future__ import annotations

from rmvdsl.grammar import ast
from rmvdsl.grammar import formula as fm
from rmvdsl.lang.numbers import decimal


def quote(value: str) -> str:
    """A string literal whose decoding gives back `value` (see build_base.unescape)."""
    out = ['"']
    for index, char in enumerate(value):
        if char == '"':
            out.append('\\"')
        elif char == "\\":
            following = value[index + 1] if index + 1 < len(value) else ""
            out.append("\\\\" if following in ('"', "\\", "") else "\\")
        else:
            out.append(char)
    out.append('"')
    return "".join(out)


def value(node: ast.Node) -> str:
    match node:
        case ast.StringLit():
            return quote(node.value)
        case ast.NumberLit() | ast.RateLit():
            return node.text
        case ast.TimeLit():
            return node.time.text
        case ast.BoolLit():
            return "true" if node.value else "false"
        case ast.NameValue():
            return node.ident.name
        case ast.EnvRef():
            return f"env({quote(node.variable.value)})"
        case ast.ListValue():
            return "[" + ", ".join(value(item) for item in node.items) + "]"
    raise TypeError(f"not a value: {node!r}")


def setting(node: ast.Setting) -> str:
    return f"{node.key.name} = {value(node.value)}"


def action(node: ast.Action) -> str:
    if not node.args:
        return f"action {node.kind.name}"
    return f"action {node.kind.name}({', '.join(argument(arg) for arg in node.args)})"


def argument(arg: ast.Arg) -> str:
    return value(arg.value) if arg.key is None else f"{arg.key.name} = {value(arg.value)}"


# ---- expressions ----

_EXPR_PRECEDENCE = {
    "or": 1,
    "and": 2,
    "=": 4,
    "!=": 4,
    "<": 4,
    "<=": 4,
    ">": 4,
    ">=": 4,
    "=~": 4,
    "!~": 4,
    "|": 5,
    "^": 6,
    "&": 7,
    "+": 8,
    "-": 8,
    "*": 9,
    "/": 9,
    "%": 9,
}
_NOT, _NEG, _ATOM = 3, 10, 11


def expression(node: ast.Node) -> str:
    return _expr(node, 0)


def _expr(node: ast.Node, minimum: int) -> str:
    text, precedence = _expr_with_precedence(node)
    return f"({text})" if precedence < minimum else text


def _expr_with_precedence(node: ast.Node) -> tuple[str, int]:
    match node:
        case ast.BinOp():
            precedence = _EXPR_PRECEDENCE[node.op]
            comparison = precedence == 4
            left = _expr(node.left, precedence + 1 if comparison else precedence)
            right = _expr(node.right, precedence + 1)
            return f"{left} {node.op} {right}", precedence
        case ast.UnaryOp() if node.op == "not":
            return f"not {_expr(node.operand, _NOT)}", _NOT
        case ast.UnaryOp():
            return f"-{_expr(node.operand, _NEG)}", _NEG
        case ast.Call():
            return f"{node.func.name}({', '.join(_expr(a, 0) for a in node.args)})", _ATOM
        case ast.NameRef():
            return node.ident.name, _ATOM
    return value(node), _ATOM


# ---- formulas ----

_FORMULA_PRECEDENCE = {"->": 1, "<->": 1, "or": 2, "and": 3}
_TEMPORAL_BINARY, _COMPARE, _UNARY, _F_ATOM = 4, 4.5, 5, 6
_TERM_PRECEDENCE = {"+": 1, "-": 1, "*": 2}


def formula(node: fm.Formula) -> str:
    return _formula(node, 0)


def _formula(node: fm.Formula, minimum: float) -> str:
    text, precedence = _formula_with_precedence(node)
    return f"({text})" if precedence < minimum else text


def _formula_with_precedence(node: fm.Formula) -> tuple[str, float]:
    match node:
        case fm.Prop():
            return node.name, _F_ATOM
        case fm.Const():
            return ("true" if node.value else "false"), _F_ATOM
        case fm.Not():
            return f"not {_formula(node.operand, _UNARY)}", _UNARY
        case fm.Binary():
            precedence = _FORMULA_PRECEDENCE[node.op]
            if node.op == "->":  # right associative
                left, right = _formula(node.left, 2), _formula(node.right, 1)
            elif node.op == "<->":
                left, right = _formula(node.left, 2), _formula(node.right, 2)
            else:
                left, right = _formula(node.left, precedence), _formula(node.right, precedence + 1)
            return f"{left} {node.op} {right}", precedence
        case fm.Temporal() if node.left is not None:
            left = _formula(node.left, _UNARY)
            right = _formula(node.right, _UNARY)
            return f"{left} {node.op}{bound(node.bound)} {right}", _TEMPORAL_BINARY
        case fm.Temporal():
            return f"{node.op}{bound(node.bound)} {_formula(node.right, _UNARY)}", _UNARY
        case fm.Compare():
            # Parenthesised under `not` and temporal operators, where it reads
            # ambiguously without (the tree is the same either way).
            return f"{term(node.left)} {node.op} {term(node.right)}", _COMPARE
    raise TypeError(f"not a formula: {node!r}")


def bound(node: fm.Bound | None) -> str:
    return "" if node is None else f"[{node.op}{node.value.text}]"


def term(node: fm.Term, minimum: int = 0) -> str:
    match node:
        case fm.Number():
            text = node.time.text if node.time is not None else decimal(abs(node.value))
            if node.value < 0 and not text.startswith("-"):
                text = "-" + text
            return text
        case fm.Duration():
            return f"duration[{node.window.text}]({formula(node.body)})"
        case fm.Arith():
            precedence = _TERM_PRECEDENCE[node.op]
            text = f"{term(node.left, precedence)} {node.op} {term(node.right, precedence + 1)}"
            if precedence < minimum:
                raise ValueError("a term that needs parentheses cannot be printed in .rmv")
            return text
    raise TypeError(f"not a term: {node!r}")
