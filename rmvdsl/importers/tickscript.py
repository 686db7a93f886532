"""The alert TICKscripts of rostopicmon (thesis 3.4.5) to a .rmv `alert`.

Only the shape the thesis uses is read: `stream |from() .measurement('M')
|alert()` with `.info/.warn/.crit(lambda: ...)`, their `...Reset` lambdas and the
handlers `.post`, `.tcp`, `.exec`, `.log`, `.message`, `.id`, `.stateChangesOnly`.
Everything else is reported, never silently dropped.
"""

from __future__ import annotations

import re

from rmvdsl.grammar.printer import quote
from rmvdsl.importers.influxql import influx_expression

_METHOD = re.compile(r"\.\s*([A-Za-z]+)\s*\(")
_LEVELS = ("info", "warn", "crit")


def _arguments(script: str, start: int) -> tuple[str, int]:
    """The text between the parenthesis at `start` and its match, and the end."""
    depth = 0
    quote_char = ""
    index = start
    while index < len(script):
        char = script[index]
        if quote_char:
            if char == "\\":
                index += 1
            elif char == quote_char:
                quote_char = ""
        elif char in "'\"":
            quote_char = char
        elif char == "(":
            depth += 1
        elif char == ")":
            depth -= 1
            if depth == 0:
                return script[start + 1 : index], index + 1
        index += 1
    return script[start + 1 :], len(script)


def _strip_comments(script: str) -> str:
    """Remove `//` comments, but not `//` inside strings (URLs)."""
    pieces = re.findall(r"""'(?:\\.|[^'\\])*'|"(?:\\.|[^"\\])*"|//[^\n]*|[^'"/]+|/""", script)
    return "".join(piece for piece in pieces if not piece.startswith("//"))


def _string_argument(text: str) -> str | None:
    match = re.match(r"""^\s*(['"])(.*?)\1\s*$""", text, re.DOTALL)
    return match.group(2) if match else None


def _lambda(text: str, measurement: str) -> str:
    body = re.sub(r"^\s*lambda\s*:\s*", "", text)
    body = body.replace('"value"', f'"{measurement}"')
    return influx_expression(body).replace("==", "=")


def convert_tickscript(script: str, name: str) -> tuple[str | None, list[str]]:
    notes: list[str] = []
    script = _strip_comments(script)
    methods = []
    for match in _METHOD.finditer(script):
        arguments, _ = _arguments(script, match.end() - 1)
        methods.append((match.group(1), arguments))
    measurement = next((_string_argument(a) for m, a in methods if m == "measurement"), None)
    if not measurement:
        return None, [f"alert `{name}`: no `.measurement('...')` found: not carried over"]
    conditions: dict[str, str] = {}
    resets: dict[str, str] = {}
    members: list[str] = []
    for method, arguments in methods:
        if method in _LEVELS:
            conditions[method] = _lambda(arguments, measurement)
        elif method.endswith("Reset") and method[:-5] in _LEVELS:
            resets[method[:-5]] = _lambda(arguments, measurement)
        elif method in ("post", "tcp", "exec", "log"):
            members.append(_handler(method, arguments, notes))
        elif method == "message":
            text = _string_argument(arguments)
            if text is not None:
                members.append(f"    message {quote(text)}")
        elif method == "id":
            text = _string_argument(arguments)
            if text is not None:
                members.append(f"    id = {quote(text)}")
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


def _handler(method: str, arguments: str, notes: list[str]) -> str:
    parts = [p for p in (_string_argument(a) for a in _split(arguments)) if p is not None]
    if method == "log":
        notes.append(
            f"`.log({arguments.strip()})` writes a file in Kapacitor; it becomes `action log`"
        )
        return "    action log"
    if not parts:
        notes.append(f"`.{method}({arguments.strip()})` has no string argument: not carried over")
        return ""
    if method == "exec" and len(parts) > 1:
        return f"    action exec({quote(parts[0])}, {quote(' '.join(parts[1:]))})"
    return f"    action {method}({quote(parts[0])})"


def _split(arguments: str) -> list[str]:
    return [piece for piece in re.split(r",(?=(?:[^'\"]*['\"][^'\"]*['\"])*[^'\"]*$)", arguments)]
