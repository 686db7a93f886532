"""What ROS itself has every node do, against the spec's whitelists (RMV225).

With `infrastructure = ros` (the default) every node may use ROS's own topics
(builtins.INFRASTRUCTURE) unless a whitelist names the topic: then that whitelist
decides, and every node it does not list is reported, though every node uses the
topic. With `infrastructure = none`, a node declaration that does not list them is
reported for what ROS has it do. Both are said here, before the monitor runs.
"""

from __future__ import annotations

import re

from rmvdsl.check.model import Model
from rmvdsl.check.msgtypes import ROS1_DISTROS
from rmvdsl.check.whitelists import ROLES, quoted, topic_of
from rmvdsl.grammar import ast
from rmvdsl.lang.builtins import INFRASTRUCTURE
from rmvdsl.lang.diagnostics import Diagnostic, Fix, Label, warning
from rmvdsl.lang.source import Span
from rmvdsl.runtime.spec import pattern


def infrastructure_warnings(model: Model) -> list[Diagnostic]:
    setting = _setting(model)
    if setting is None or setting.value.ident.name == "ros":  # type: ignore[union-attr]
        return _tightened(model)
    return _undeclared(model, setting)


def _setting(model: Model) -> ast.Setting | None:
    if model.intrusion is None:
        return None
    for setting in model.intrusion.settings:
        if setting.key.name == "infrastructure" and isinstance(setting.value, ast.NameValue):
            return setting
    return None


def _tightened(model: Model) -> list[Diagnostic]:
    """A whitelist naming one of ROS's own topics: its lists decide there."""
    found = []
    for whitelist in model.whitelists:
        topic = topic_of(model, whitelist)
        for role, _, does, _ in ROLES:
            allowed = getattr(whitelist, role)
            used = [v for v, given in INFRASTRUCTURE.items() if topic in given[role[:-1]]]
            if allowed is None or not used or any(a.value in ("*", "/*") for a in allowed):
                continue
            on = " and ".join(f"ROS {v}" for v in used)
            found.append(
                warning(
                    "RMV225",
                    f"every node {does} `{topic}` on {on}, and this whitelist allows only "
                    f"the {role} it lists: the monitor reports every other node",
                    whitelist.target.span,
                    label=f"replaces `infrastructure = ros` on `{topic}`",
                    help=f'allow every node with `{role}: "*"`, or remove this whitelist '
                    "(docs/language.md, `intrusion`)",
                )
            )
    return found


def _undeclared(model: Model, setting: ast.Setting) -> list[Diagnostic]:
    """`infrastructure = none`: a node declaration that leaves out what ROS has
    every node do is reported for it."""
    version = 1 if model.ros is not None and model.ros.distro.name in ROS1_DISTROS else 2
    given = INFRASTRUCTURE[version]
    found = []
    for node in model.nodes:
        for role, node_role, does, _ in ROLES:
            listed = getattr(node, node_role)
            if listed is None:
                continue
            missing = [t for t in given[role[:-1]] if not _matches(listed, t)]
            if not missing:
                continue
            names = ", ".join(f"`{t}`" for t in missing)
            found.append(
                warning(
                    "RMV225",
                    f"node `{node.name.value}` does not list ROS's own topics it {does} "
                    f"on ROS {version} ({names}): with `infrastructure = none` the monitor "
                    "reports it when it uses them",
                    node.name.span,
                    label=f"what this node {does}",
                    secondary=[Label(setting.span, "ROS's own topics are not allowed")],
                    help="list them in the declaration, or remove `infrastructure = none`",
                    fixes=_appended(listed, missing, node_role),
                )
            )
    return found


def _matches(patterns: tuple[ast.StringLit, ...], name: str) -> bool:
    return any(re.match(pattern(p.value).regex, name) for p in patterns)


def _appended(items: tuple[ast.StringLit, ...], names: list[str], role: str) -> tuple[Fix, ...]:
    if not items:
        return ()
    last = items[-1].span
    text = "".join(f", {quoted(n)}" for n in names)
    return (
        Fix(f"Add ROS's own topics to what it {role}", Span(last.path, last.end, last.end), text),
    )
