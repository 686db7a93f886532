"""Expressions as the resolved spec holds them (rmvdsl.runtime.spec): typed, names
resolved to what they read, operators as the runtime spells them.

One lowering for every reader of a condition: rmvdsl.ir builds the resolved spec
with it (the runtime, the replay and every target run that), and the solver stage
(rmvdsl.check.conditions) encodes the very same typed trees in z3, so the model
`rmv check` reasons about is the one the runtime executes.
"""

from __future__ import annotations

from rmvdsl.check.model import Kind, Model
from rmvdsl.check.types import TypeInfo
from rmvdsl.check.vtypes import VType
from rmvdsl.grammar import ast
from rmvdsl.lang import builtins
from rmvdsl.runtime import spec as ir

_EXPRESSION_OPS = {"<>": "!="}


class NotLowered(ValueError):
    """A tree the checker let through but the resolved spec cannot hold."""


def value_type(value: VType) -> ir.ValueType:
    return ir.ValueType(value.kind, value.ros, value.rate)


def lower_expr(model: Model, types: TypeInfo, node: ast.Node) -> ir.Expr:
    value = value_type(types.type_of(node))
    match node:
        case ast.NumberLit():
            return ir.Number(node.text, node.value, value)
        case ast.StringLit():
            return ir.String(node.value, value)
        case ast.BoolLit():
            return ir.Boolean(node.value, value)
        case ast.TimeLit():
            seconds = node.time.seconds(model.time_unit)
            if seconds is None:
                raise NotLowered("a time without a unit")
            return ir.Time(node.time.text, seconds, value)
        case ast.NameRef():
            return ir.Ref(node.ident.name, ref_kind(model, node.ident.name), value)
        case ast.UnaryOp():
            return ir.Unary(node.op, lower_expr(model, types, node.operand), value)
        case ast.BinOp():
            op = _EXPRESSION_OPS.get(node.op, node.op)
            left, right = lower_expr(model, types, node.left), lower_expr(model, types, node.right)
            return ir.Binary(op, left, right, value)
        case ast.Call():
            try:
                builtins.function(node.func.name)
            except builtins.UnknownBuiltin:  # the names stage said so (a damaged source)
                raise NotLowered(f"no function `{node.func.name}`") from None
            args = tuple(lower_expr(model, types, a) for a in node.args)
            return ir.Call(node.func.name, args, value)
    raise NotLowered(f"not an expression: {type(node).__name__}")


def ref_kind(model: Model, name: str) -> str:
    symbol = model.symbols.get(name)
    if symbol is None:
        raise NotLowered(f"`{name}` is not declared")
    if symbol.kind is Kind.VARIABLE:
        return "variable"
    return "emitted" if symbol.kind is Kind.EMITTED_EVENT else "event"
