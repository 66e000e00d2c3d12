"""Atomic outputs: complete or absent, previous version kept on failure, ordinary permissions."""

from __future__ import annotations

import os
import stat

import pytest

from nightloc.io import atomic as _atomic


def _mode(path):
    return stat.S_IMODE(os.stat(path).st_mode)


def test_file_replaces_only_on_success(tmp_path):
    target = tmp_path / "out.txt"
    _atomic.write_text(target, "old\n")
    with pytest.raises(RuntimeError), _atomic.atomic_file(target, "w") as stream:  # noqa: PT012 - fails mid-write
        stream.write("half")
        raise RuntimeError("interrupted")
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]  # no temporary left behind
    _atomic.write_bytes(target, b"new")
    assert target.read_bytes() == b"new"


def test_permissions_follow_the_umask(tmp_path):
    previous = os.umask(0o022)
    try:
        _atomic.write_text(tmp_path / "a.txt", "x")
        with _atomic.atomic_folder(tmp_path / "folder") as staging:
            (staging / "f").write_text("y")
    finally:
        os.umask(previous)
    assert _mode(tmp_path / "a.txt") == 0o644
    assert _mode(tmp_path / "folder") == 0o755


def test_folder_replaces_only_on_success(tmp_path):
    target = tmp_path / "traverse"
    with _atomic.atomic_folder(target) as staging:
        (staging / "one").write_text("1")
    with pytest.raises(ValueError, match="bad image"), _atomic.atomic_folder(target) as staging:  # noqa: PT012
        (staging / "two").write_text("2")
        raise ValueError("bad image")
    assert sorted(p.name for p in target.iterdir()) == ["one"]
    with _atomic.atomic_folder(target) as staging:
        (staging / "three").write_text("3")
    assert sorted(p.name for p in target.iterdir()) == ["three"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["traverse"]


def test_refuses_a_folder_as_file_target(tmp_path):
    with pytest.raises(IsADirectoryError):
        _atomic.write_text(tmp_path, "x")
