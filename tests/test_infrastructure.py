"""ROS's own topics against the spec's whitelists (RMV225): the checker says what
`infrastructure` implies, and the runtime does what the checker said."""

from __future__ import annotations

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime.engine import Endpoint, Runtime


def _check(tmp_path, text):
    path = tmp_path / "spec.rmv"
    path.write_text(text, encoding="utf-8")
    return check(str(path), solver=False)


def _codes(result):
    return [(d.code, d.message) for d in result.diagnostics if d.code == "RMV225"]


def _intruders(result, endpoints, ros_version):
    runtime = Runtime(lower(result), ros_version=ros_version)
    runtime.start(0)
    runtime.graph(0, endpoints)
    return [(r["node"], r["topic"]) for r in runtime.records() if r["kind"] == "intrusion"]


def test_a_whitelist_naming_ros_s_own_topic_is_said_and_decides(tmp_path):
    result = _check(tmp_path, 'system s\nwhitelist "/rosout" { publishers: "/logger" }\n')
    (code,) = _codes(result)
    assert "every node publishes `/rosout`" in code[1]
    endpoints = [
        Endpoint("/logger", "/rosout", "publisher"),
        Endpoint("/a", "/rosout", "publisher"),
    ]
    assert _intruders(result, endpoints, 2) == [("/a", "/rosout")]


def test_a_whitelist_allowing_every_node_is_not_said(tmp_path):
    result = _check(tmp_path, 'system s\nwhitelist "/rosout" { publishers: "*" }\n')
    assert _codes(result) == []


def test_by_default_ros_s_own_topics_are_no_intrusion(tmp_path):
    text = 'system s\nintrusion { default = deny }\nnode "/a" { publishes: "/cmd" }\n'
    result = _check(tmp_path, text)
    assert _codes(result) == []
    endpoints = [Endpoint("/a", t, "publisher") for t in ("/cmd", "/rosout", "/parameter_events")]
    endpoints.append(Endpoint("/a", "/clock", "subscriber"))
    assert _intruders(result, endpoints, 2) == [("/a", "/cmd")]  # no whitelist, deny
    assert _intruders(result, endpoints[:2], 1) == [("/a", "/cmd")]


def test_with_infrastructure_none_a_node_must_list_them(tmp_path):
    text = (
        "system s\nros noetic\nintrusion { infrastructure = none }\n"
        'node "/a" { publishes: "/cmd" }\nnode "/b" { publishes: "/cmd", "/rosout" }\n'
    )
    result = _check(tmp_path, text)
    (code,) = _codes(result)
    assert code[1].startswith("node `/a` does not list ROS's own topics it publishes on ROS 1")
    (fix,) = next(d for d in result.diagnostics if d.code == "RMV225").fixes
    assert fix.text == ', "/rosout"'
    endpoints = [Endpoint(n, "/rosout", "publisher") for n in ("/a", "/b")]
    assert _intruders(result, endpoints, 1) == [("/a", "/rosout")]
