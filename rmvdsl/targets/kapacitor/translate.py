"""The resolved spec's expressions as InfluxQL and TICKscript trees (the dialect
modules print them, with their one quoting rule): exactly, or Unsupported."""

from __future__ import annotations

from rmvdsl.dialects import influxql
from rmvdsl.dialects import tickscript as tick
from rmvdsl.runtime import spec as ir
from rmvdsl.targets import TargetError


class BuildError(TargetError):
    """A spec this target cannot express."""


class Unsupported(Exception):
    """An expression with no exact InfluxQL or TICKscript counterpart."""


# The spec's operators that InfluxQL has, as InfluxQL writes them.
_INFLUXQL_OPS = {"=": "=", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">=",
                 "+": "+", "-": "-", "*": "*", "/": "/", "%": "%", "&": "&", "|": "|",
                 "^": "^", "and": "AND", "or": "OR"}  # fmt: skip


def influxql_expression(expr: ir.Expr) -> influxql.Expr:
    """An event's expression (or `where` condition) in InfluxQL."""
    match expr:
        case ir.Number():
            return influxql.Literal(expr.text)
        case ir.String():
            return influxql.Text(expr.value)
        case ir.Boolean():
            return influxql.Literal("true" if expr.value else "false")
        case ir.Time():
            return influxql.Literal(influxql.duration(expr.seconds))
        case ir.Ref():
            return influxql.Name(expr.name)
        case ir.Unary(op="-"):
            return influxql.Unary("-", influxql_expression(expr.operand))
        case ir.Unary():
            raise Unsupported(f"InfluxQL has no `{expr.op}`")
        case ir.Binary():
            op = _INFLUXQL_OPS.get(expr.op)
            if op is None:
                raise Unsupported(f"InfluxQL has no `{expr.op}`")
            left, right = influxql_expression(expr.left), influxql_expression(expr.right)
            return influxql.Binary(op, left, right)
        case ir.Call():
            return influxql.Call(expr.function, tuple(influxql_expression(a) for a in expr.args))
    raise Unsupported(f"no InfluxQL for {type(expr).__name__}")


_TICK_OPS = {"=": "==", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">=",
             "+": "+", "-": "-", "*": "*", "and": "AND", "or": "OR"}  # fmt: skip


def tick_expression(expr: ir.Expr) -> tick.Expr:
    """An alert condition as a TICKscript lambda's body. InfluxQL's `/` (always a
    division of doubles) divides two `float()`s; what has no exact counterpart
    (functions, `%`, bitwise operators) is Unsupported."""
    match expr:
        case ir.Number():
            return tick.Literal(expr.text)
        case ir.String():
            return tick.Text(expr.value)
        case ir.Boolean():
            return tick.Literal("TRUE" if expr.value else "FALSE")
        case ir.Time():
            return tick.Literal(tick.duration(expr.seconds))
        case ir.Ref():
            return tick.Reference(expr.name)
        case ir.Unary():
            return tick.Unary("-" if expr.op == "-" else "!", tick_expression(expr.operand))
        case ir.Binary(op="/"):
            left, right = tick_expression(expr.left), tick_expression(expr.right)
            return tick.Binary("/", tick.Call("float", (left,)), tick.Call("float", (right,)))
        case ir.Binary():
            op = _TICK_OPS.get(expr.op)
            if op is None:
                raise Unsupported(f"TICKscript has no exact `{expr.op}`")
            return tick.Binary(op, tick_expression(expr.left), tick_expression(expr.right))
    raise Unsupported(f"TICKscript lambdas have no `{getattr(expr, 'function', expr)}`")
