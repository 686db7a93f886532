"""`rmv replay` and `rmv build` of a spec whose inputs are unchanged since its last
clean check load the IR it stored then (rmvdsl.commands.stored_spec) and import no
checker; any change of what the check read checks again."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

# A command in a process of its own, as a user's shell starts it (its arguments in
# place of ARGS), saying which of the checker's modules it imported.
COMMAND = (
    "import sys\n"
    "from rmvdsl.cli import main\n"
    "code = main(ARGS)\n"
    "checker = sorted(m for m in sys.modules if m.split('.')[0] in ('lark', 'z3', 'networkx')\n"
    "                 or m.startswith('rmvdsl.check'))\n"
    "print(json.dumps({'code': code, 'checker': checker}))\n"
)
REPLAY = COMMAND.replace("ARGS", "['replay', *sys.argv[1:], '--format', 'jsonl', '--quiet']")
BUILD = COMMAND.replace("ARGS", "['build', sys.argv[1], '--target', 'ir', '-o', sys.argv[2]]")


def _spec(folder: Path, limit: str = "5", field: str = "value") -> Path:
    (folder / "msg" / "lab" / "msg").mkdir(parents=True, exist_ok=True)
    (folder / "msg" / "lab" / "msg" / "Reading.msg").write_text(f"float64 {field}\n")
    spec = folder / "reading.rmv"
    spec.write_text(
        'system reading "a reading"\nros noetic\nmessages "msg"\n'
        'topic reading: lab/Reading = "/reading"\nvar Value = reading.value\n'
        f"event Big when Value > {limit}\nproperty Small: not Big\n",
        encoding="utf-8",
    )
    return spec


def _bag(path: Path) -> Path:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg("float64 value\n", "lab/msg/Reading"))
    reading = store.types["lab/msg/Reading"]
    with Writer(path) as writer:
        connection = writer.add_connection("/reading", "lab/msg/Reading", typestore=store)
        for k in range(10):
            data = store.serialize_ros1(reading(value=float(k)), "lab/msg/Reading")
            writer.write(connection, (1_700_000_000 + k) * 10**9, data)
    return path


def _replay(cache: Path, *args: str) -> tuple[dict, list[dict], str]:
    run = subprocess.run(
        [sys.executable, "-c", "import json\n" + REPLAY, *args],
        capture_output=True, text=True, timeout=120, cwd=cache.parent,
        env={**os.environ, "RMV_CACHE_DIR": str(cache)},
    )  # fmt: skip
    lines = run.stdout.splitlines()
    assert lines, run.stderr
    return json.loads(lines[-1]), [json.loads(line) for line in lines[:-1]], run.stderr


def _build(cache: Path, spec: Path, out: Path) -> tuple[dict, str]:
    run = subprocess.run(
        [sys.executable, "-c", "import json\n" + BUILD, str(spec), str(out)],
        capture_output=True, text=True, timeout=120, cwd=cache.parent,
        env={**os.environ, "RMV_CACHE_DIR": str(cache)},
    )  # fmt: skip
    return json.loads(run.stdout.splitlines()[-1]), run.stderr


def _verdicts(records: list[dict]) -> list[tuple]:
    return [(r["verdict"], r["from"], r["to"]) for r in records if r["kind"] == "verdict"]


@pytest.fixture
def setup(tmp_path: Path) -> tuple[Path, Path, Path]:
    return _spec(tmp_path), _bag(tmp_path / "run.bag"), tmp_path / "cache"


def test_a_second_replay_of_an_unchanged_spec_imports_no_checker(setup):
    spec, bag, cache = setup
    first, records, _ = _replay(cache, str(spec), str(bag))
    assert first["code"] == 1 and "rmvdsl.check" in first["checker"], first
    second, again, _ = _replay(cache, str(spec), str(bag))
    assert second == {"code": 1, "checker": []}
    assert again == records  # the same records, byte for byte once decoded
    assert _verdicts(records) == [
        ("true", 1_700_000_000, 1_700_000_006),
        ("false", 1_700_000_006, 1_700_000_009),
    ]


def test_an_edit_of_the_spec_or_a_message_definition_checks_again(setup):
    spec, bag, cache = setup
    _replay(cache, str(spec), str(bag))
    _spec(spec.parent, limit="7")  # another bound: another verdict
    edited, records, _ = _replay(cache, str(spec), str(bag))
    assert "rmvdsl.check" in edited["checker"]
    assert _verdicts(records)[1] == ("false", 1_700_000_008, 1_700_000_009)
    # The definition no longer has the field the spec reads: an error, not a replay.
    _spec(spec.parent, limit="7", field="reading")
    broken, records, err = _replay(cache, str(spec), str(bag))
    assert broken["code"] == 1 and not records and "RMV" in err, err
    assert "rmv replay:" in err and "error: nothing replayed" in err


def test_options_that_change_the_check_have_entries_of_their_own(setup):
    spec, bag, cache = setup
    _replay(cache, str(spec), str(bag))
    other, _, _ = _replay(cache, str(spec), str(bag), "--ros", "humble")
    assert "rmvdsl.check" in other["checker"]
    assert len(list((cache / "checks").iterdir())) == 2


def test_a_damaged_entry_is_checked_again_and_replaced(setup):
    spec, bag, cache = setup
    _replay(cache, str(spec), str(bag))
    (entry,) = (cache / "checks").iterdir()
    stored = json.loads(entry.read_text())
    stored["stdout"] = "{not an IR"
    entry.write_text(json.dumps(stored))
    damaged, records, _ = _replay(cache, str(spec), str(bag))
    assert "rmvdsl.check" in damaged["checker"] and len(_verdicts(records)) == 2
    again, _, _ = _replay(cache, str(spec), str(bag))
    assert again["checker"] == []


def test_what_the_store_keeps_loads_as_the_spec_it_was(rmv):
    """The example's lowered spec, written and read as the store does, is the same
    spec (a value its JSON would not give back is never stored)."""
    from rmvdsl.check import check
    from rmvdsl.ir import lower
    from rmvdsl.runtime import spec as ir

    for path in sorted((ROOT / "examples").glob("*/*.rmv")):
        result = check(str(path))
        if not result.errors:
            lowered = lower(result)
            assert ir.load(ir.dump(lowered, indent=None)) == lowered, path


def test_the_key_names_the_installed_versions_without_importlib_metadata():
    """A stored check or spec is keyed by the installs of rosbags and z3: their
    versions as their .dist-info folders name them (an upgrade checks again), read
    without importlib.metadata; a package with none is asked of importlib.metadata."""
    from importlib import metadata

    from rmvdsl.commands.stored import _installed

    for module, distribution in (("rosbags", "rosbags"), ("z3", "z3-solver")):
        found = _installed(module, distribution)
        assert isinstance(found, list) and len(found) == 1, found
        assert found[0].endswith(f"-{metadata.version(distribution)}.dist-info")
    assert _installed("no_such_module_here", "no-such-module-here") is None


def test_a_build_of_an_unchanged_spec_imports_no_checker(setup):
    """A build loads the IR a replay or a build stored (one entry for both) and
    writes what a build that checks writes; an edit checks again."""
    spec, bag, cache = setup
    first, _ = _build(cache, spec, cache.parent / "first.json")
    assert first["code"] == 0 and "rmvdsl.check" in first["checker"], first
    second, _ = _build(cache, spec, cache.parent / "second.json")
    assert second == {"code": 0, "checker": []}
    written = (cache.parent / "first.json").read_bytes()
    assert (cache.parent / "second.json").read_bytes() == written
    replayed, _, _ = _replay(cache, str(spec), str(bag))
    assert replayed["checker"] == []  # the build's entry
    _spec(spec.parent, limit="7")
    edited, _ = _build(cache, spec, cache.parent / "edited.json")
    assert "rmvdsl.check" in edited["checker"]
    assert (cache.parent / "edited.json").read_bytes() != written


def test_a_spec_that_checks_nothing_is_never_stored(tmp_path):
    """A build of a spec that checks nothing says so (RMV226) every time and builds
    it; its IR is not stored, so a replay of it is still refused."""
    spec = _spec(tmp_path)
    spec.write_text(spec.read_text().replace("property Small: not Big\n", ""))
    cache = tmp_path / "cache"
    for name in ("first", "second"):
        built, err = _build(cache, spec, tmp_path / f"{name}.json")
        assert built["code"] == 0 and "rmvdsl.check" in built["checker"], built
        assert "RMV226" in err and (tmp_path / f"{name}.json").exists()
    replayed, records, err = _replay(cache, str(spec), str(_bag(tmp_path / "run.bag")))
    assert replayed["code"] == 2 and not records and "checks nothing" in err, err


def test_a_spec_with_errors_builds_nothing_and_is_not_stored(tmp_path):
    spec = _spec(tmp_path, field="reading")  # the definition lacks the field read
    cache = tmp_path / "cache"
    for _ in range(2):
        built, err = _build(cache, spec, tmp_path / "out.json")
        assert built["code"] == 1 and "rmvdsl.check" in built["checker"], built
        assert "error" in err and ": nothing built" in err, err
    assert not (tmp_path / "out.json").exists()
