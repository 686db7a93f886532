"""ROS naming rules for topics, nodes and message types.

Topic and node names follow the ROS 2 rules (which also hold for ROS 1 graph
names): tokens of letters, digits and underscores separated by `/`, no token
starting with a digit, no empty token, no trailing `/`; `~` may lead (private).
Whitelist patterns may use `*` for any run of characters.
"""

from __future__ import annotations

import re

_TOKEN = r"[A-Za-z_][A-Za-z0-9_]*"
_NAME = re.compile(rf"^(~/?|/)?{_TOKEN}(/{_TOKEN})*$")
_PACKAGE = re.compile(r"^[a-z][a-z0-9_]*$")
_TYPE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def name_problem(name: str, what: str, patterns: bool = False) -> str | None:
    """Why `name` is not a valid ROS topic or node name, or None when it is."""
    if not name:
        return f"a {what} name cannot be empty"
    if patterns and "*" in name:
        # Check the name with every `*` standing for one plain character.
        probe = name.replace("*", "x")
        problem = name_problem(probe, what)
        return problem.replace(probe, name) if problem else None
    if name == "/":
        return f"`/` alone is not a {what} name"
    if "//" in name:
        return f"`{name}` has an empty token (`//`)"
    if name.endswith("/"):
        return f"`{name}` ends with `/`"
    if " " in name:
        return f"`{name}` contains a space"
    for token in name.lstrip("~/").split("/"):
        if token and token[0].isdigit():
            return f"the token `{token}` of `{name}` starts with a digit"
    bad = [c for c in name if not (c.isalnum() or c in "_/~") or not c.isascii()]
    if bad:
        return f"`{name}` contains `{bad[0]}`, which ROS names do not allow"
    if not _NAME.match(name):
        return f"`{name}` is not a valid ROS {what} name"
    return None


def suggest_name(name: str) -> str:
    """A corrected name to offer in `help:` lines."""
    cleaned = re.sub(r"[^A-Za-z0-9_/~*]", "_", name.strip())
    cleaned = re.sub(r"/+", "/", cleaned).rstrip("/") or "/name"
    tokens = [("_" + t if t[:1].isdigit() else t) for t in cleaned.split("/")]
    return "/".join(tokens)


def message_type_problem(parts: list[str]) -> str | None:
    if len(parts) not in (2, 3):
        return "a message type is `package/Type` or `package/msg/Type`"
    if len(parts) == 3 and parts[1] != "msg":
        return f"the middle part of a ROS 2 message type is `msg`, not `{parts[1]}`"
    package, type_name = parts[0], parts[-1]
    if not _PACKAGE.match(package):
        return f"the package name `{package}` must be lower case letters, digits and `_`"
    if not _TYPE.match(type_name):
        return f"the type name `{type_name}` must be a letter then letters, digits or `_`"
    return None
