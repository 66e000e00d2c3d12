"""Result sets (:func:`nightloc.io.atomic.output_set`): a command's output folder appears whole or
not at all, keeps what nightloc did not write, takes one writer at a time, and never writes where
it must not (a missing parent, the current folder, a link loop).

Each test states the old behaviour it would have caught: before sets, commands wrote their files
one by one into the folder and deleted names by pattern.
"""

from __future__ import annotations

import json
import os
import threading

import pytest

from nightloc.io import atomic
from nightloc.io.atomic import MANIFEST_NAME, output_set


def _tree(root):
    """{relative path: bytes} of every file under ``root`` (symbolic links as their target text)."""
    out = {}
    for path in sorted(root.rglob("*")):
        if path.is_symlink():
            out[path.relative_to(root).as_posix()] = ("link", os.readlink(path))
        elif path.is_file():
            out[path.relative_to(root).as_posix()] = path.read_bytes()
    return out


def _write_set(target, files, command="test", **options):
    with output_set(target, command=command, **options) as out:
        for name, text in files.items():
            (out / name).parent.mkdir(parents=True, exist_ok=True)
            (out / name).write_text(text)
    return target


def _hidden(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_success_leaves_the_new_set_and_its_manifest(tmp_path):
    out = _write_set(tmp_path / "out", {"a.csv": "1", "sub/b.png": "2"})
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    assert manifest["command"] == "test" and manifest["files"] == ["a.csv", "sub/b.png"]
    assert manifest["folders"] == ["sub"]
    _write_set(out, {"c.csv": "3"})  # a new set replaces every file of the old one
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "c.csv"]
    assert _hidden(tmp_path) == [], "no staging folder, lock file or previous folder left beside the set"


@pytest.mark.parametrize("failure", [ValueError("bad frame"), KeyboardInterrupt()], ids=["error", "Ctrl-C"])
def test_failure_on_the_last_file_leaves_the_previous_set_whole(tmp_path, failure):
    """Old behaviour: the first files were rewritten and the run then failed on the last one."""
    out = _write_set(tmp_path / "out", {"errors.csv": "old", "summary.csv": "old"})
    before = _tree(out)
    with pytest.raises(type(failure)), output_set(out, command="test") as staged:  # noqa: PT012
        (staged / "errors.csv").write_text("new")
        (staged / "summary.csv").write_text("new")
        raise failure
    assert _tree(out) == before
    assert _hidden(tmp_path) == []


def test_files_nightloc_did_not_write_are_kept(tmp_path):
    """Old behaviour: ``evaluate --no-figures`` deleted the user's ``heatmap_frame_notes.png``
    (a glob over names it had not written)."""
    out = _write_set(tmp_path / "out", {"errors.csv": "1", "heatmap_frame5.png": "fig", "world/errors.csv": "w"})
    (out / "heatmap_frame_notes.png").write_text("my notes")
    (out / "world" / "README.txt").write_text("mine too")  # inside a folder nightloc made
    (out / "mine").mkdir()
    (out / "mine" / "data.bin").write_bytes(b"\x00\x01")
    os.symlink("errors.csv", out / "link-to-errors")
    inode = (out / "heatmap_frame_notes.png").stat().st_ino
    _write_set(out, {"errors.csv": "2"})
    assert (out / "heatmap_frame_notes.png").read_text() == "my notes"
    assert (out / "heatmap_frame_notes.png").stat().st_ino == inode, "kept by a hard link, not copied"
    assert (out / "world" / "README.txt").read_text() == "mine too"
    assert (out / "mine" / "data.bin").read_bytes() == b"\x00\x01"
    assert os.readlink(out / "link-to-errors") == "errors.csv"
    assert not (out / "heatmap_frame5.png").exists() and not (out / "world" / "errors.csv").exists()
    assert (out / "errors.csv").read_text() == "2"
    # and the next set still knows which files are the user's
    _write_set(out, {"errors.csv": "3"})
    assert (out / "world" / "README.txt").read_text() == "mine too"


def test_a_users_file_where_the_set_writes_one_fails_and_keeps_both(tmp_path):
    out = _write_set(tmp_path / "out", {"errors.csv": "1"})
    (out / "pr.csv").write_text("the user's own pr.csv")
    with pytest.raises(FileExistsError, match=r"pr\.csv was not written by nightloc"):
        _write_set(out, {"errors.csv": "2", "pr.csv": "nightloc's"})
    assert (out / "pr.csv").read_text() == "the user's own pr.csv" and (out / "errors.csv").read_text() == "1"


def test_a_file_added_during_the_swap_is_moved_into_the_new_set(tmp_path, monkeypatch):
    """A user's file written between the carrying-over and the swap must not vanish with the old
    folder."""
    out = _write_set(tmp_path / "out", {"errors.csv": "1"})
    real = atomic.replace_folder

    def swap_while_the_user_writes(staging, target, keep_previous=False):
        (out / "late.txt").write_text("written at the last moment")
        return real(staging, target, keep_previous)

    monkeypatch.setattr(atomic, "replace_folder", swap_while_the_user_writes)
    _write_set(out, {"errors.csv": "2"})
    assert (out / "late.txt").read_text() == "written at the last moment"
    assert _hidden(tmp_path) == []


def test_a_folder_not_written_by_nightloc_is_refused_and_an_empty_one_used(tmp_path):
    user = tmp_path / "photos"
    user.mkdir()
    (user / "holiday.jpg").write_bytes(b"jpeg")
    with pytest.raises(FileExistsError, match="did not write"):
        _write_set(user, {"errors.csv": "1"})
    assert _tree(user) == {"holiday.jpg": b"jpeg"}
    empty = tmp_path / "empty"
    empty.mkdir()
    _write_set(empty, {"errors.csv": "1"})
    assert (empty / "errors.csv").read_text() == "1"
    damaged = _write_set(tmp_path / "damaged", {"a": "1"})
    (damaged / MANIFEST_NAME).write_text("{ not json")
    with pytest.raises(FileExistsError, match="damaged"):
        _write_set(damaged, {"a": "2"})


def test_user_data_is_replaced_only_when_asked(tmp_path):
    dataset = _write_set(tmp_path / "data", {"dataset.json": "seed 0"}, command="synth")
    with pytest.raises(FileExistsError, match="--overwrite"):
        _write_set(dataset, {"dataset.json": "seed 7"}, overwrite=False)
    assert (dataset / "dataset.json").read_text() == "seed 0"
    _write_set(dataset, {"dataset.json": "seed 7"}, overwrite=True)
    assert (dataset / "dataset.json").read_text() == "seed 7"


def test_a_second_writer_refuses_at_once_or_waits(tmp_path):
    """Old behaviour: two runs into one folder mixed their files, both exiting 0."""
    target = tmp_path / "out"
    with output_set(target, command="first") as first:
        (first / "a.csv").write_text("first")
        with pytest.raises(BlockingIOError, match=r"another nightloc run \(process \d+\) is writing") as info:
            _write_set(target, {"a.csv": "second"})
        assert "\n" not in str(info.value)
        done = []
        waiting = threading.Thread(target=lambda: done.append(_write_set(target, {"a.csv": "third"}, wait=30)))
        waiting.start()
        waiting.join(0.3)
        assert waiting.is_alive(), "a writer with wait= waits for the lock"
    waiting.join(30)
    assert done and (target / "a.csv").read_text() == "third"
    assert _hidden(tmp_path) == []


def test_outputs_need_an_existing_parent_and_never_replace_the_working_folder(tmp_path, monkeypatch):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        _write_set(tmp_path / "no" / "such" / "out", {"a": "1"})
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "file").write_text("x")
    with pytest.raises(NotADirectoryError):
        _write_set(tmp_path / "file", {"a": "1"})
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    for target in (work, tmp_path, "."):
        with pytest.raises(ValueError, match="current folder"):
            _write_set(target, {"a": "1"})


def test_a_symbolic_link_is_followed_and_a_loop_refused(tmp_path):
    real = _write_set(tmp_path / "real", {"a": "1"})
    os.symlink(real, tmp_path / "link")
    _write_set(tmp_path / "link", {"b": "2"})
    assert (tmp_path / "link").is_symlink(), "the link stays"
    assert sorted(p.name for p in real.iterdir()) == [MANIFEST_NAME, "b"]
    os.symlink(tmp_path / "loop", tmp_path / "loop")
    with pytest.raises(ValueError, match="symbolic link loop"):
        _write_set(tmp_path / "loop", {"a": "1"})


def test_a_file_written_through_a_symbolic_link_replaces_its_target(tmp_path):
    real = tmp_path / "maps" / "garden.map"
    real.parent.mkdir()
    real.write_text("old")
    os.symlink(real, tmp_path / "current.map")
    atomic.write_text(tmp_path / "current.map", "new")
    assert (tmp_path / "current.map").is_symlink() and real.read_text() == "new"
    with pytest.raises(FileExistsError):
        atomic.write_text(tmp_path / "current.map", "newer", overwrite=False)


def test_leftovers_of_killed_writes_are_cleaned_and_a_half_swap_is_repaired(tmp_path):
    """Old behaviour: ``.partial`` entries of killed saves piled up."""
    out = _write_set(tmp_path / "out", {"a": "1"})
    (tmp_path / ".out.0123456789ab.partial").mkdir()  # a killed run's staging folder
    (tmp_path / ".out.0123456789ab.partial" / "a").write_text("half")
    (tmp_path / ".out.lock").write_text("12345\n")  # a killed run's lock (released by its death)
    (tmp_path / ".other.0123456789ab.partial").write_text("another target's: not ours to remove")
    _write_set(out, {"a": "2"})
    assert _hidden(tmp_path) == [".other.0123456789ab.partial"]
    # the two-rename swap killed between its renames: the old folder waits under its .old name
    os.rename(out, tmp_path / ".out.fedcba987654.old")
    (tmp_path / "keep.txt").write_text("x")
    os.rename(tmp_path / "keep.txt", tmp_path / ".out.fedcba987654.old" / "notes.txt")  # a user's file in it
    _write_set(out, {"b": "new"})  # the old folder is restored first, so its user's file survives
    assert (out / "b").read_text() == "new" and (out / "notes.txt").read_text() == "x"
    assert _hidden(tmp_path) == [".other.0123456789ab.partial"]


def test_files_take_turns_and_a_new_file_is_written_once(tmp_path):
    """Two writers of a new file with ``overwrite=False``: exactly one succeeds (checked under
    the lock); the other gets FileExistsError."""
    target = tmp_path / "map.map"
    results = []
    barrier = threading.Barrier(8)

    def write(i):
        barrier.wait()
        try:
            atomic.write_text(target, f"writer {i}", overwrite=False)
            results.append(i)
        except FileExistsError:
            results.append(None)

    threads = [threading.Thread(target=write, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    winners = [r for r in results if r is not None]
    assert len(winners) == 1 and target.read_text() == f"writer {winners[0]}"
    assert _hidden(tmp_path) == []
