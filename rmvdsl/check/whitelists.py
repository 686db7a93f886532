"""Whether the two kinds of whitelist agree (part of the names stage).

A topic's whitelist names the nodes allowed on it; a node's names the topics it may
use. When a node's declaration says it publishes (or subscribes to) a topic whose
whitelist does not allow that node, or a topic's whitelist allows a node whose
declaration does not list the topic, the monitor would report an intrusion for
an endpoint the spec itself declares: RMV222, with the edit that adds the name.
Only exact names are compared (a pattern on both sides may or may not overlap).
"""

from __future__ import annotations

import re
from collections.abc import Iterator

from rmvdsl.check.model import Model
from rmvdsl.grammar import ast
from rmvdsl.lang.diagnostics import Diagnostic, Fix, Label, warning
from rmvdsl.lang.source import Span
from rmvdsl.runtime.spec import pattern

# (a whitelist's list, a node's list, what the node does, said both ways)
ROLES = (
    ("publishers", "publishes", "publishes", "publish"),
    ("subscribers", "subscribes", "subscribes to", "subscribe to"),
)


def check_whitelist_agreement(model: Model) -> list[Diagnostic]:
    found = []
    for role, node_role, does, to_do in ROLES:
        for node, topic_lit, whitelist in _conflicts_node_side(model, role, node_role):
            found.append(_node_lacks_topic_side(model, node, topic_lit, whitelist, role, does))
        for whitelist, node_lit, node in _conflicts_topic_side(model, role, node_role):
            found.append(_topic_lacks_node_side(model, whitelist, node_lit, node, node_role, to_do))
    return found


def topic_of(model: Model, decl: ast.WhitelistDecl) -> str:
    """The ROS name (or pattern) a whitelist is for."""
    if isinstance(decl.target, ast.Ident):
        topic = model.topics.get(decl.target.name)
        return topic.path.value if topic else decl.target.name
    return decl.target.value


def _exact(text: str) -> bool:
    return "*" not in text


def _matches(patterns: tuple[ast.StringLit, ...], name: str) -> bool:
    return any(re.match(pattern(p.value).regex, name) for p in patterns)


def _conflicts_node_side(
    model: Model, role: str, node_role: str
) -> Iterator[tuple[ast.NodeDecl, ast.StringLit, ast.WhitelistDecl]]:
    """A node declared to use a topic whose whitelist does not allow the node."""
    for node in model.nodes:
        if not _exact(node.name.value):
            continue
        for topic in getattr(node, node_role) or ():
            if not _exact(topic.value):
                continue
            for whitelist in model.whitelists:
                allowed = getattr(whitelist, role)
                on_topic = re.match(pattern(topic_of(model, whitelist)).regex, topic.value)
                if on_topic and allowed is not None and not _matches(allowed, node.name.value):
                    yield node, topic, whitelist


def _conflicts_topic_side(
    model: Model, role: str, node_role: str
) -> Iterator[tuple[ast.WhitelistDecl, ast.StringLit, ast.NodeDecl]]:
    """A topic's whitelist allowing a node whose declaration omits the topic."""
    for whitelist in model.whitelists:
        topic = topic_of(model, whitelist)
        if not _exact(topic):
            continue
        for allowed in getattr(whitelist, role) or ():
            for node in model.nodes:
                uses = getattr(node, node_role)
                named = re.match(pattern(node.name.value).regex, allowed.value)
                omitted = uses is not None and not _matches(uses, topic)
                if _exact(allowed.value) and named and omitted:
                    yield whitelist, allowed, node


def _appended(items: tuple[ast.StringLit, ...] | None, name: str, title: str) -> tuple[Fix, ...]:
    """The edit adding `name` after the last item of a list (none for an empty one:
    `none` is replaced by hand)."""
    if not items:
        return ()
    last = items[-1].span
    return (Fix(title, Span(last.path, last.end, last.end), f", {quoted(name)}"),)


def quoted(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _node_lacks_topic_side(
    model: Model,
    node: ast.NodeDecl,
    topic: ast.StringLit,
    whitelist: ast.WhitelistDecl,
    role: str,
    verb: str,
) -> Diagnostic:
    name, where = node.name.value, topic_of(model, whitelist)
    title = f"Add {quoted(name)} to the {role} of the whitelist of {where}"
    return warning(
        "RMV222",
        f"node `{name}` {verb} `{topic.value}`, but the whitelist of `{where}` does not allow it: "
        "the monitor would report it as an intrusion",
        topic.span,
        label=f"declared by node `{name}`",
        secondary=[Label(whitelist.target.span, f"the {role} allowed on `{where}`")],
        help=f"add {quoted(name)} to the {role} of that whitelist, or remove `{topic.value}` here",
        fixes=_appended(getattr(whitelist, role), name, title),
    )


def _topic_lacks_node_side(
    model: Model,
    whitelist: ast.WhitelistDecl,
    allowed: ast.StringLit,
    node: ast.NodeDecl,
    node_role: str,
    verb: str,
) -> Diagnostic:
    topic = topic_of(model, whitelist)
    title = f"Add {quoted(topic)} to what node {node.name.value} {node_role}"
    return warning(
        "RMV222",
        f"the whitelist of `{topic}` allows `{allowed.value}`, but node `{node.name.value}` "
        f"is not declared to {verb} it: the monitor would report it as an intrusion",
        allowed.span,
        label="allowed here",
        secondary=[Label(node.name.span, f"what this node {node_role}")],
        help=f"add {quoted(topic)} to `{node_role}` of node `{node.name.value}`, "
        f"or remove `{allowed.value}` from this whitelist",
        fixes=_appended(getattr(node, node_role), topic, title),
    )
