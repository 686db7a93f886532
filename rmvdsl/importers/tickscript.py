"""The alert TICKscripts of rostopicmon (thesis 3.4.5) to a .rmv `alert`.

Read with the TICKscript dialect's parser. Only the shape the thesis uses is
carried over: `stream |from() .measurement('M') |alert()` with
`.info/.warn/.crit(lambda: ...)`, their `...Reset` lambdas and the handlers
`.post`, `.tcp`, `.exec`, `.log`, `.message`, `.id`, `.stateChangesOnly`,
`.noRecoveries`. Everything else is reported, never silently dropped.
"""

from __future__ import annotations

from fractions import Fraction

from rmvdsl.dialects import tickscript as tick
from rmvdsl.grammar import ast, printer
from rmvdsl.grammar.printer import quote
from rmvdsl.importers.influxql import IDENTIFIER as _IDENT

_LEVELS = ("info", "warn", "crit")

_RMV_OPS = {"OR": "or", "AND": "and", "==": "="}


def rmv_expression(expr: tick.Expr, measurement: str) -> str:
    """A lambda's body in .rmv syntax, printed by .rmv's own printer (parentheses
    where .rmv's binding needs them); the reference "value" names the measurement
    (rostopicmon's field)."""
    return printer.expression(_node(expr, measurement))


def _node(expr: tick.Expr, measurement: str) -> ast.Expr:
    """The .rmv syntax tree of a TICKscript expression."""
    match expr:
        case tick.Reference():
            name = measurement if expr.name == "value" else expr.name
            return ast.NameRef(ast.Ident(name)) if _IDENT.match(name) else ast.StringLit(name)
        case tick.Text():
            return ast.StringLit(expr.value)
        case tick.Literal() if expr.text in ("TRUE", "FALSE"):
            return ast.BoolLit(expr.text == "TRUE")
        case tick.Literal():
            return ast.NumberLit(_number(expr.text), expr.text)
        case tick.Unary():
            op = "not" if expr.op == "!" else "-"
            return ast.UnaryOp(op, _node(expr.operand, measurement))
        case tick.Binary():
            left, right = _node(expr.left, measurement), _node(expr.right, measurement)
            return ast.BinOp(_RMV_OPS.get(expr.op, expr.op), left, right)
        case tick.Call():
            args = tuple(_node(a, measurement) for a in expr.args)
            return ast.Call(ast.Ident(expr.function), args)
    # What .rmv has no expression for (a lambda, a bare word): as TICKscript wrote it,
    # for the import's check to report.
    return ast.NameRef(ast.Ident(tick.expression(expr)))


def _number(text: str) -> Fraction:
    """A literal's value where it is a number (the printer writes `text` as is)."""
    try:
        return Fraction(text)
    except ValueError:
        return Fraction(0)


def _steps(statements: list[tick.Statement]) -> list[tick.Step]:
    return [step for s in statements if isinstance(s, tick.Pipeline) for step in s.steps]


def _text(arg: tick.Expr) -> str | None:
    """A string argument's value (the thesis also wrote URLs in double quotes)."""
    if isinstance(arg, tick.Text):
        return arg.value
    return arg.name if isinstance(arg, tick.Reference) else None


def _single_text(step: tick.Step) -> str | None:
    return _text(step.args[0]) if len(step.args) == 1 else None


def _lambda(step: tick.Step, measurement: str) -> str | None:
    if len(step.args) == 1 and isinstance(step.args[0], tick.Lambda):
        return rmv_expression(step.args[0].body, measurement)
    return None


def _written(step: tick.Step) -> str:
    return f".{step.name}({', '.join(tick.expression(a) for a in step.args)})"


def convert_tickscript(script: str, name: str) -> tuple[str | None, list[str]]:
    try:
        steps = _steps(tick.parse(script))
    except tick.TickError as why:
        return None, [f"alert `{name}`: not TICKscript ({why}): not carried over"]
    notes: list[str] = []
    measurement = next((_single_text(s) for s in steps if s.name == "measurement"), None)
    if not measurement:
        return None, [f"alert `{name}`: no `.measurement('...')` found: not carried over"]
    conditions: dict[str, str] = {}
    resets: dict[str, str] = {}
    members: list[str] = []
    for step in steps:
        method = step.name
        if method in _LEVELS or (method.endswith("Reset") and method[:-5] in _LEVELS):
            condition = _lambda(step, measurement)
            if condition is None:
                written = _written(step)
                notes.append(f"alert `{name}`: `{written}` is not a lambda: not carried over")
            elif method in _LEVELS:
                conditions[method] = condition
            else:
                resets[method[:-5]] = condition
        elif method in ("post", "tcp", "exec", "log"):
            members.append(_handler(step, notes))
        elif method in ("message", "id"):
            text = _single_text(step)
            if text is not None:
                members.append(f"    {method}{' =' if method == 'id' else ''} {quote(text)}")
        elif method == "stateChangesOnly":
            members.append("    state_changes_only = true")
        elif method == "noRecoveries":
            members.append("    no_recoveries = true")
        elif method not in ("from", "alert", "measurement"):
            notes.append(f"alert `{name}`: `.{method}(...)` is not carried over")
    if not conditions:
        return None, [*notes, f"alert `{name}`: no .info/.warn/.crit condition: not carried over"]
    levels = []
    for level in _LEVELS:
        if level in conditions:
            reset = f" reset when {resets[level]}" if level in resets else ""
            levels.append(f"    {level} when {conditions[level]}{reset}")
    body = "\n".join([*levels, *(m for m in members if m)])
    return f"alert {name} {{\n{body}\n}}", notes


def _handler(step: tick.Step, notes: list[str]) -> str:
    written = _written(step)
    if step.name == "log":
        notes.append(f"`{written}` writes a file in Kapacitor; it becomes `action log`")
        return "    action log"
    parts = [p for p in (_text(a) for a in step.args) if p is not None]
    if not parts:
        notes.append(f"`{written}` has no string argument: not carried over")
        return ""
    if step.name == "exec" and len(parts) > 1:
        return f"    action exec({quote(parts[0])}, {quote(' '.join(parts[1:]))})"
    return f"    action {step.name}({quote(parts[0])})"
