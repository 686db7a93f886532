"""`rmv import`: the thesis's YAML (figure 3.13, sections 3.5 and 3.6) to .rmv."""

from __future__ import annotations

import shutil

from conftest import EXAMPLES, FIXTURES, rmv_process

from rmvdsl.check import check
from rmvdsl.importers.thesis_yaml import convert_files

THESIS = FIXTURES / "thesis"


CARLA_MSGS = (str(EXAMPLES / "carla" / "msg"),)


def test_figure_3_13_converts_to_a_clean_spec(tmp_path):
    result = convert_files([str(THESIS / "rostopicmon.yaml")])
    spec = tmp_path / "mon.rmv"
    spec.write_text(result.text, encoding="utf-8")
    checked = check(str(spec), messages=CARLA_MSGS)
    assert checked.errors == []
    model = checked.model
    assert model.topics["carl_info"].msg_type.text == "carla_msgs/CarlaEgoVehicleStatus"
    assert model.variables["BrakePedal"].source.text == "control.brake"
    event = model.events["EderivativeVelocity"]
    assert event.clause("range").value.time.text == "1s"
    assert event.clause("group").value.interval.time.text == "100ms"
    alert = model.alerts["monitor1"]
    assert [level.severity.name for level in alert.levels] == ["info", "warn", "crit"]
    assert [a.kind.name for a in alert.actions] == ["post", "exec"]
    assert 'password = env("RMV_INFLUX_PASSWORD")' in result.text
    assert 'rmvcps"' not in result.text.split("password")[1].split("\n")[0]
    assert any("password is not copied" in note for note in result.notes)
    assert any(":30:5:" in note and "event_resample" in note for note in result.notes)


def test_thesis_ver_config_keeps_its_window_and_reports_open_names():
    result = convert_files([str(THESIS / "rostopicmon.yaml"), str(THESIS / "rostopicver.yaml")])
    assert "window = 4s" in result.text
    assert "\\until{<10}" in result.text
    assert "A -> B on EventA emit EventD" in result.text
    open_names = next(n for n in result.notes if "used but not defined" in n)
    for name in ("EventA", "HardBraking", "AntiLockBrake", "Stopped"):
        assert name in open_names


def test_intrusion_whitelists(tmp_path):
    result = convert_files(
        [str(THESIS / "rostopicmon.yaml"), str(THESIS / "rostopicintrusion.yaml")]
    )
    spec = tmp_path / "all.rmv"
    spec.write_text(result.text, encoding="utf-8")
    checked = check(str(spec), messages=CARLA_MSGS)
    assert checked.errors == []
    whitelists = {
        w.target.name if hasattr(w.target, "name") else w.target.value: w
        for w in checked.model.whitelists
    }
    status = whitelists["carl_info"]  # the topic declared by the monitoring config
    assert [p.value for p in status.subscribers] == ["/rostopicmon", "/rostopic_*"]
    assert whitelists["/clock"].subscribers is None
    assert checked.model.nodes[0].name.value == "/carla_ros_bridge"


def test_anchors_and_aliases(tmp_path):
    config = tmp_path / "aliases.yaml"
    config.write_text(
        'topics:\n  - name: &status "status"\n    topic: "/carla/hero/vehicle_status"\n'
        'variables:\n  - name: "Velocity"\n    topic: *status\n    topic_var_path: "velocity"\n'
        'events:\n  - &speed\n    event_name: "Speed"\n    event_select: "mean(\\"Velocity\\")"\n'
        '    event_groupby: "time(1s)"\n  - <<: *speed\n    event_name: "Speed2"\n',
        encoding="utf-8",
    )
    result = convert_files([str(config)])
    assert "var Velocity = status.velocity" in result.text
    assert "event Speed = mean(Velocity)" in result.text
    assert "event Speed2 = mean(Velocity)" in result.text


def test_undefined_alias_is_reported_with_position(tmp_path):
    # Section 3.4.6.3 of the thesis prints `*car1_info` for the anchor `&carl_info`.
    config = tmp_path / "typo.yaml"
    config.write_text(
        'topics:\n  - name: &carl_info "carl_info"\n    topic: "/carla/hero/vehicle_status"\n'
        'variables:\n  - name: "Velocity"\n    topic: *car1_info\n    topic_var_path: "velocity"\n',
        encoding="utf-8",
    )
    result = rmv_process(["import", str(config)])
    assert result.code == 2
    assert f"{config}:6:12: found undefined alias 'car1_info'" in result.err
    assert "Traceback" not in result.err


def test_unknown_topic_type_and_bad_entries_are_notes(tmp_path):
    config = tmp_path / "odd.yaml"
    config.write_text(
        'topics:\n  - name: "cam"\n    topic: "/camera/info"\n'
        'variables:\n  - name: "W"\n    topic: "nowhere"\n    topic_var_path: "width"\n'
        'events:\n  - event_name: "Bad"\n    event_select: "mean(W"\n'
        "extras: 1\n",
        encoding="utf-8",
    )
    result = convert_files([str(config)])
    notes = "\n".join(result.notes)
    assert "unknown_msgs/Unknown" in result.text and "no message type" in notes
    assert "unknown topic `nowhere`" in notes
    assert "`mean(W` is not an expression" in notes
    assert "unknown section `extras`" in notes


def test_missing_tickscript_is_a_note(tmp_path):
    shutil.copy(THESIS / "rostopicmon.yaml", tmp_path / "config.yaml")
    result = convert_files([str(tmp_path / "config.yaml")])
    assert any("maxvelocity.tick: no such file" in note for note in result.notes)
    assert "alert" not in result.text


def test_cli_writes_output_file(tmp_path):
    out = tmp_path / "carla.rmv"
    result = rmv_process(
        ["import", str(THESIS / "rostopicmon.yaml"), "-o", str(out), "--name", "carla"]
    )
    assert result.code == 0
    assert out.read_text(encoding="utf-8").splitlines()[1] == "system carla"
    assert "ros noetic" in out.read_text(encoding="utf-8")
    assert f"wrote {out}" in result.err


def test_thesis_horizon_is_reported_after_import(tmp_path):
    # Issue 3: the thesis's ABSCheck keeps 4 s of data for a formula that needs 10.
    result = convert_files([str(THESIS / "rostopicmon.yaml"), str(THESIS / "rostopicver.yaml")])
    spec = tmp_path / "thesis.rmv"
    spec.write_text(result.text, encoding="utf-8")
    horizon = [d for d in check(str(spec), messages=CARLA_MSGS).errors if d.code == "RMV318"]
    assert len(horizon) == 1
    assert horizon[0].message == "the window of `ABSCheck` (4s) is shorter than its horizon (10s)"
