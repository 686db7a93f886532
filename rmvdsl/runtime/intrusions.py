"""Intrusion detection: whether an endpoint of the ROS graph (node, topic, role)
is allowed by the spec's whitelists, node rules and `intrusion` block."""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from rmvdsl.lang.builtins import INFRASTRUCTURE
from rmvdsl.runtime import spec as ir


@dataclass(frozen=True)
class Endpoint:
    node: str
    topic: str
    role: str  # publisher | subscriber
    # False: a connection the ROS master never heard of (ROS 1: a peer that reached
    # a node directly); `node` is then the peer's address or claimed name.
    registered: bool = True


def _matches(patterns: Iterable[ir.Pattern], name: str) -> bool:
    return any(re.match(p.regex, name) for p in patterns)


def can_refuse(spec: ir.Spec) -> bool:
    """Whether any endpoint could be an intrusion (else the graph need not be read)."""
    return bool(spec.whitelists or spec.nodes or spec.intrusion.default == "deny")


def verdict_of(
    spec: ir.Spec, endpoint: Endpoint, ros_version: int | None = None
) -> tuple[str, Any] | None:
    """Why an endpoint is not allowed (and the rule that refused it), or None, on a
    system of `ros_version` (default: the spec's). An endpoint the master never
    registered is refused whatever the lists say: it went round them."""
    if not endpoint.registered:
        does = "publishes on" if endpoint.role == "publisher" else "subscribes to"
        return f"{does} {endpoint.topic} without registering with the ROS master", None
    if _matches(spec.intrusion.ignore_nodes, endpoint.node):
        return None
    publisher = endpoint.role == "publisher"
    lists = [w for w in spec.whitelists if re.match(w.topic.regex, endpoint.topic)]
    intrusion = spec.intrusion
    if intrusion.infrastructure == "ros" and not lists:
        given = INFRASTRUCTURE.get(ros_version or spec.ros.version, {})
        infrastructure = given.get(endpoint.role, ())
    else:
        infrastructure = ()
    if endpoint.topic in infrastructure:
        return None  # ROS's own, which every node uses (docs/runtime.md, "Intrusions")
    # The reason says what and why; the record and the action's text say who.
    for rule in lists:
        allowed = rule.publishers if publisher else rule.subscribers
        if allowed is not None and not _matches(allowed, endpoint.node):
            return f"not in the {endpoint.role}s allowed on {rule.topic.text}", rule
    if not lists and intrusion.default == "deny":
        does = "publishes on" if publisher else "subscribes to"
        return f"{does} {endpoint.topic}, which has no whitelist, and the default is deny", None
    for node_rule in spec.nodes:
        if re.match(node_rule.node.regex, endpoint.node):
            allowed = node_rule.publishes if publisher else node_rule.subscribes
            verb = "publish" if publisher else "subscribe"
            if allowed is not None and not _matches(allowed, endpoint.topic):
                rule_name = node_rule.node.text
                by = f" (node {rule_name})" if rule_name != endpoint.node else ""
                return f"may not {verb} on {endpoint.topic}{by}", node_rule
    return None
