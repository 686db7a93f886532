"""Small conversions of lowering: setting values, credentials, name patterns, the
names an event reads, primitive types."""

from __future__ import annotations

from typing import Any

from rmvdsl.check.msgdefs import FieldType
from rmvdsl.grammar import ast
from rmvdsl.grammar.formula import TIME_UNITS
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.spec import pattern


class LowerError(ValueError):
    """The spec has errors: only an error-free check result lowers."""


def setting_value(node: ast.Value) -> Any:
    """A setting's or argument's value as the resolved spec holds it."""
    match node:
        case ast.StringLit():
            return node.value
        case ast.NumberLit():
            return int(node.value) if node.value.denominator == 1 else node.value
        case ast.TimeLit():
            assert node.time.unit is not None, "a time without a unit passed the checker"
            return node.time.value * TIME_UNITS[node.time.unit]
        case ast.RateLit():
            return node.hertz
        case ast.BoolLit():
            return node.value
        case ast.NameValue():
            return node.ident.name
        case ast.EnvRef():
            return ast.EnvRef(node.variable)
        case ast.ListValue():
            return tuple(setting_value(item) for item in node.items)
    raise LowerError(f"not a value: {type(node).__name__}")


def credential(value: Any) -> ir.Credential | None:
    if value is None:
        return None
    if isinstance(value, ast.EnvRef):
        return ir.Credential(env=value.variable.value)
    return ir.Credential(value=value)


def patterns(items: tuple[ast.StringLit, ...] | None) -> tuple[ir.Pattern, ...] | None:
    return None if items is None else tuple(pattern(i.value) for i in items)


def reads(decl: ast.EventDecl) -> set[str]:
    where = decl.clause("where")
    return ast.names_in(decl.expr) | (ast.names_in(where.value) if where else set())


def primitive(base: str) -> bool:
    return FieldType(base).is_primitive
