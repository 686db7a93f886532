"""The message registry reads a folder's .msg files once and again only when they
change: an editor checks at every keystroke, a sourced ROS workspace holds
hundreds of packages."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from rmvdsl.check import check, msgfolders

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
