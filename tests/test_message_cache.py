"""The message registry reads a folder's .msg files once and again only when they
change: an editor checks at every keystroke, a sourced ROS workspace holds
hundreds of packages."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from rmvdsl.check import check, msgfolders
from rmvdsl.util.cache import flush

SPEC = 'system cached\nmessages "msg"\ntopic S: demo_msgs/Status = "/s"\nvar V = S.{field}\n'


def _write(path: Path, text: str, bump: int = 0) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    if bump:  # a later modification time, whatever the file system's resolution
        stat = path.stat()
        os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + bump * 1_000_000_000))


def _codes(spec: Path) -> list[str]:
    return [d.code for d in check(str(spec), use_environment=False).diagnostics]


@pytest.fixture
def reads(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    seen: list[str] = []
    original = msgfolders._read_msg

    def counted(name: str, path: str) -> msgfolders._FileRead:
        seen.append(name)
        return original(name, path)

    monkeypatch.setattr(msgfolders, "_read_msg", counted)
    return seen


def test_files_are_read_again_only_when_they_change(tmp_path: Path, reads: list[str]):
    status = tmp_path / "msg" / "demo_msgs" / "msg" / "Status.msg"
    _write(status, "float64 speed\n")
    spec = tmp_path / "cached.rmv"
    spec.write_text(SPEC.format(field="gear"), encoding="utf-8")
    assert "RMV301" in _codes(spec)  # no field `gear` yet
    assert reads == ["demo_msgs/msg/Status"]
    assert "RMV301" in _codes(spec)
    assert reads == ["demo_msgs/msg/Status"]  # unchanged: not read again
    _write(status, "float64 speed\nuint8 gear\n", bump=1)
    assert "RMV301" not in _codes(spec)
    assert reads == ["demo_msgs/msg/Status"] * 2


def test_a_new_package_is_found(tmp_path: Path, reads: list[str]):
    _write(tmp_path / "msg" / "other_msgs" / "msg" / "Other.msg", "int32 x\n")
    spec = tmp_path / "cached.rmv"
    spec.write_text(SPEC.format(field="speed"), encoding="utf-8")
    assert "RMV300" in _codes(spec)  # demo_msgs/Status is not there yet
    _write(tmp_path / "msg" / "demo_msgs" / "msg" / "Status.msg", "float64 speed\n")
    os.utime(tmp_path / "msg", ns=(0, os.stat(tmp_path / "msg").st_mtime_ns + 10**9))
    assert "RMV300" not in _codes(spec)


def test_a_broken_file_keeps_its_diagnostic_from_the_cache(tmp_path: Path):
    _write(tmp_path / "msg" / "demo_msgs" / "msg" / "Status.msg", "float64\n")
    spec = tmp_path / "cached.rmv"
    spec.write_text(SPEC.format(field="speed"), encoding="utf-8")
    first, second = _codes(spec), _codes(spec)
    assert "RMV304" in first and first == second


@pytest.mark.parametrize("distro", ["noetic", "humble", "jazzy"])
def test_a_kept_store_gives_the_definitions_rosbags_gives(distro, tmp_path, monkeypatch):
    """The standard messages are kept in the cache folder (rosbags builds its store
    in 120-210 ms a process); what is read back is what rosbags' store says."""
    from rmvdsl.check import msgtypes

    monkeypatch.setenv("RMV_CACHE_DIR", str(tmp_path))
    fresh = msgtypes._read_store(distro, msgtypes.builtins.TYPE_STORES[distro])
    msgtypes._store_definitions.cache_clear()
    try:
        assert msgtypes._store_definitions(distro) == fresh  # read, then kept
        flush()
        assert len(list((tmp_path / "stores").iterdir())) == 1
        msgtypes._store_definitions.cache_clear()
        monkeypatch.setattr(msgtypes, "_read_store", _never_read)
        assert msgtypes._store_definitions(distro) == fresh  # from the kept file
        kept = next((tmp_path / "stores").iterdir())
        kept.write_text('{"std_msgs/msg/Bool": {"fields": 3}}', encoding="utf-8")
        msgtypes._store_definitions.cache_clear()
        monkeypatch.undo()
        monkeypatch.setenv("RMV_CACHE_DIR", str(tmp_path))
        assert msgtypes._store_definitions(distro) == fresh  # a damaged file: read again
    finally:
        msgtypes._store_definitions.cache_clear()


def _never_read(distro: str, store_name: str) -> None:
    raise AssertionError(f"the {store_name} store was read, not taken from the cache folder")


def test_a_check_of_a_standard_message_imports_no_rosbags_once_its_store_is_kept(tmp_path):
    import subprocess
    import sys

    spec = tmp_path / "standard.rmv"
    spec.write_text('system s\ntopic T: std_msgs/Float64 = "/t"\nvar V = T.data\n'
                    "event E when V > 1\n", encoding="utf-8")  # fmt: skip
    code = (
        "import sys; from rmvdsl.check import check; "
        f"found = check({str(spec)!r}, use_environment=False).diagnostics; "
        "assert not [d for d in found if d.severity.name == 'ERROR'], found; "
        "print(sorted(m for m in sys.modules if m.startswith('rosbags.typesys')))"
    )
    env = {**os.environ, "RMV_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, check=True) for _ in range(2)]  # fmt: skip
    first, second = (run.stdout.strip() for run in runs)
    assert first != "[]" and second == "[]"
