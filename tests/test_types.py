"""Types: message definitions, field paths, expression rules, units, horizons."""

from __future__ import annotations

from fractions import Fraction

import pytest
from conftest import EXAMPLES
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rmvdsl.check import check
from rmvdsl.check.msgdefs import parse_msg
from rmvdsl.grammar import ast
from rmvdsl.grammar.parser import parse_source
from rmvdsl.lang.source import SourceFile

ABS = EXAMPLES / "carla" / "abs.rmv"
CARLA_MSGS = str(EXAMPLES / "carla" / "msg")


def check_text(text: str, tmp_path, name: str = "spec.rmv", **options):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return check(str(path), **options)


def codes(result) -> list[str]:
    return [d.code for d in result.diagnostics]


STATUS = 'topic s: carla_msgs/CarlaEgoVehicleStatus = "/carla/hero/vehicle_status"\n'


def test_variable_types_are_known_to_the_model():
    result = check(str(ABS))
    types = result.types
    assert types.variables["Velocity"].ros == "float32"
    assert types.variables["HandBrake"].kind == "bool"
    assert types.variables["FastestObject"].kind == "float"
    assert types.events["EderivativeVelocity"].rate == -1
    assert types.events["HardBrake"].kind == "bool"


@pytest.mark.parametrize(
    ("ros", "good", "bad", "hint"),
    [
        ("noetic", "header.stamp.secs", "header.stamp.sec", "did you mean `secs`?"),
        ("humble", "header.stamp.sec", "header.stamp.secs", "did you mean `sec`?"),
        ("noetic", "header.seq", "header.sq", "did you mean `seq`?"),
        ("jazzy", "header.frame_id", "header.seq", "and its Header has no `seq`"),
    ],
)
def test_ros1_and_ros2_headers(tmp_path, ros, good, bad, hint):
    spec = STATUS + f"var Good = s.{good}\nvar Bad = s.{bad}\nalert A {{ warn when Good = Bad }}\n"
    result = check_text(spec, tmp_path, ros=ros, messages=(CARLA_MSGS,))
    assert [(d.code, d.help) for d in result.errors] == [("RMV301", result.errors[0].help)]
    assert hint in result.errors[0].help
    assert result.errors[0].span.start == spec.index(bad.split(".")[-1], spec.index("var Bad"))


def test_standard_messages_come_from_rosbags_for_each_distro(tmp_path):
    spec = (
        'topic fix: sensor_msgs/msg/NavSatFix = "/fix"\nvar Lat = fix.latitude\n'
        'topic odom: nav_msgs/Odometry = "/odom"\nvar X = odom.pose.pose.position.x\n'
        "alert A { warn when Lat > X }\n"
    )
    for ros in ("noetic", "foxy", "humble", "jazzy", "kilted"):
        assert check_text(spec, tmp_path, ros=ros).diagnostics == [], ros


def test_unknown_type_suggests_the_closest(tmp_path):
    spec = 'topic odom: nav_msgs/Odometri = "/odom"\ntopic p: geometry_msgs/Pointt = "/p"\n'
    result = check_text(spec, tmp_path)
    helps = [d.help for d in result.errors if d.code == "RMV300"]
    assert helps == [
        "did you mean `nav_msgs/msg/Odometry`?",
        "did you mean `geometry_msgs/msg/Point`?",
    ]


def test_message_folders_from_the_environment(tmp_path, monkeypatch):
    share = tmp_path / "install" / "share" / "my_msgs" / "msg"
    share.mkdir(parents=True)
    (share / "Speed.msg").write_text("float64 value\n", encoding="utf-8")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    spec = 'topic t: my_msgs/Speed = "/speed"\nvar V = t.value\nalert A { warn when V > 1 }\n'
    assert check_text(spec, tmp_path).diagnostics == []
    assert codes(check_text(spec, tmp_path, use_environment=False)) == ["RMV300"]


def test_configuration_precedence(tmp_path):
    (tmp_path / "rmv.toml").write_text('ros = "humble"\nmessages = ["m"]\n', encoding="utf-8")
    (tmp_path / "m" / "p" / "msg").mkdir(parents=True)
    (tmp_path / "m" / "p" / "msg" / "T.msg").write_text("Header header\n", encoding="utf-8")
    spec = 'topic t: p/T = "/t"\nvar S = t.header.stamp.sec\nalert A { warn when S > 1 }\n'
    assert check_text(spec, tmp_path).diagnostics == []  # humble, from rmv.toml
    assert codes(check_text("ros noetic\n" + spec, tmp_path)) == ["RMV301"]  # the spec wins
    assert (
        check_text("ros noetic\n" + spec, tmp_path, ros="jazzy").diagnostics == []
    )  # the CLI wins


def test_msg_parser_reads_every_form():
    text = (
        "# comment\nHeader header\nfloat64[] values  # trailing\nuint8[4] fixed\n"
        "int32[<=3] bounded\n"
        'string<=10 name\nstring greeting "hello"\nuint8 MODE=2\nstring TEXT=a # not a comment\n'
        "geometry_msgs/Point point\nPoint local\n"
    )
    definition, problems = parse_msg(SourceFile("p/msg/T.msg", text), "p/msg/T")
    assert problems == []
    assert {k: v.text() for k, v in definition.fields.items()} == {
        "header": "std_msgs/msg/Header",
        "values": "float64[]",
        "fixed": "uint8[4]",
        "bounded": "int32[<=3]",
        "name": "string",
        "greeting": "string",
        "point": "geometry_msgs/msg/Point",
        "local": "p/msg/Point",
    }
    assert definition.constants["TEXT"] == ("string", "a # not a comment")


def test_expression_rules_in_one_spec(tmp_path):
    spec = STATUS + (
        "var V = s.velocity\nvar H = s.control.hand_brake\nvar HN = number(s.control.hand_brake)\n"
        "event D = derivative(mean(V), 1s) group by time(100ms)\n"
        "event Ok when D < -5 and HN = 1 and H = true and V * 3.6 > 10\n"
        "event Bad when D > V\n"
        "alert A { warn when Ok or Bad }\n"
    )
    result = check_text(spec, tmp_path, messages=(CARLA_MSGS,), ros="noetic")
    assert codes(result) == ["RMV315"]


def test_horizons(tmp_path):
    spec = (
        "time unit s\n"
        "event A when true\nevent B when true\n"
        "property P31: (A -> (B or A) until[<10] B) and duration[10](A) < 4\n"
        "property Nested: always[<=60s] (A -> eventually[<=15s] B)\n"
        "property Past: once[<5s] A and historically[<=2s] B and eventually[=3s] A\n"
        "property Window: A -> eventually[<=10s] B { window = 10s }\n"
    )
    result = check_text(spec, tmp_path)
    horizons = {name: (h.future, h.past) for name, h in result.types.horizons.items()}
    assert horizons == {
        "P31": (Fraction(10), Fraction(0)),
        "Nested": (Fraction(75), Fraction(0)),
        "Past": (Fraction(3), Fraction(5)),
        "Window": (Fraction(10), Fraction(0)),
    }
    assert result.errors == []


def test_cli_options_for_types(rmv, tmp_path):
    spec = tmp_path / "s.rmv"
    spec.write_text(
        STATUS + "var T = s.header.stamp.secs\nalert A { warn when T > 1 }\n", encoding="utf-8"
    )
    assert rmv("check", "--ros", "noetic", "--messages", CARLA_MSGS, str(spec)).code == 0
    assert rmv("check", "--ros", "humble", "--messages", CARLA_MSGS, str(spec)).code == 1
    bad = rmv("check", "--ros", "rolling2", str(spec))
    assert bad.code == 2 and "unknown ROS distribution" in bad.err


# ---- mutations of the CARLA example: each must be reported, with its span ----

ABS_TEXT = ABS.read_text(encoding="utf-8")
ABS_SPEC = parse_source(SourceFile(str(ABS), ABS_TEXT)).spec
VARIABLES = [d for d in ABS_SPEC.items if isinstance(d, ast.VarDecl)]
TOPICS = [d for d in ABS_SPEC.items if isinstance(d, ast.TopicDecl)]
NOT_A_FIELD = st.from_regex(r"zz[a-z]{2,6}", fullmatch=True)


@st.composite
def mutations(draw) -> tuple[str, str, int]:
    kind = draw(st.sampled_from(["field", "type", "index", "message"]))
    if kind == "type":
        topic = draw(st.sampled_from(TOPICS))
        span = topic.msg_type.span
        replacement = f"{draw(NOT_A_FIELD)}_msgs/{draw(NOT_A_FIELD).title()}"
        return "RMV300", ABS_TEXT[: span.start] + replacement + ABS_TEXT[span.end :], span.start
    variable = draw(st.sampled_from([v for v in VARIABLES if v.aggregate is None]))
    segments = variable.source.segments
    if kind == "field":
        segment = draw(st.sampled_from(segments))
        span = segment.field_name.span
        return (
            "RMV301",
            ABS_TEXT[: span.start] + draw(NOT_A_FIELD) + ABS_TEXT[span.end :],
            span.start,
        )
    if kind == "index":
        segment = segments[-1]  # every variable of the example ends at a scalar
        span = segment.span
        return "RMV302", ABS_TEXT[: span.end] + "[0]" + ABS_TEXT[span.end :], span.start
    # end the path one segment early, at a message (or at the topic's message)
    if len(segments) < 2:
        return "RMV303", ABS_TEXT, -1
    cut = segments[-2].span.end
    return "RMV303", ABS_TEXT[:cut] + ABS_TEXT[segments[-1].span.end :], segments[-2].span.start


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutations())
def test_each_mutation_is_reported_with_its_code_and_span(mutation):
    code, text, start = mutation
    if start < 0:
        return
    result = check(str(ABS), text)
    found = [d for d in result.errors if d.code == code]
    assert found, (code, [d.message for d in result.diagnostics])
    assert any(d.span.start == start for d in found), (code, start, [d.span for d in found])
    assert {d.code for d in result.errors} <= {code, "RMV203"}


def test_idl_definitions_are_read(tmp_path):
    folder = tmp_path / "m" / "my_msgs" / "msg"
    folder.mkdir(parents=True)
    (folder / "Speed.idl").write_text(
        "module my_msgs { module msg {\n"
        "struct Speed { double value; sequence<float> history; };\n}; };\n",
        encoding="utf-8",
    )
    (folder / "Broken.idl").write_text("module my_msgs { struct { oops }; };\n", encoding="utf-8")
    spec = (
        'messages "m"\ntopic t: my_msgs/msg/Speed = "/speed"\nvar V = t.value\n'
        "var H = max(t.history[*])\nalert A { warn when V > H }\n"
    )
    result = check_text(spec, tmp_path, ros="humble")
    assert [(d.code, d.span.path.endswith("Broken.idl")) for d in result.diagnostics] == [
        ("RMV304", True)
    ]
    assert result.types.variables["V"].ros == "float64"


def test_a_rate_where_a_time_is_needed(tmp_path):
    spec = (
        STATUS
        + "var V = s.velocity\nevent E = mean(V)\n    group by time(10Hz)\n"
        + "alert A { warn when E > 1 }\n"
    )
    result = check_text(spec, tmp_path, ros="noetic", messages=(CARLA_MSGS,))
    rate = next(d for d in result.errors if d.code == "RMV316")
    assert rate.message == "`10Hz` is a rate, but a time is needed here"
    assert rate.help == "a period of 10Hz is 0.1s"
