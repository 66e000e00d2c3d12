"""No data loss: a save killed mid-way leaves the previous file or folder intact, and loading a
map verifies its checksums (a damaged file is refused, never half-read).

The kill tests run the save in a separate Python process whose writes report their progress
on stdout; this process sends SIGKILL at a chosen point (half-way through the bytes of a map,
half-way through the images of a traverse, just before the final rename) or at random times.
Nothing in the child is faked except that it pauses at the chosen point: the kill is real.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import nightloc
from nightloc import MapFormatError
from nightloc.localization.filter_tables import FILTER_ARRAYS

from reliability_support import random_frames

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL (POSIX)")

_CHILD_PRELUDE = textwrap.dedent(
    """
    import contextlib, os, sys, time
    import numpy as np
    import nightloc
    from nightloc.io import atomic as _atomic, map_file, traverse

    def say(*words):
        print(*words, flush=True)

    def wait_for_the_kill():
        say("waiting")
        time.sleep(120)
        say("not killed")
        sys.exit(3)
    """
)


def _run_until(script: str, marker: str, timeout: float = 120.0) -> subprocess.Popen:
    """Starts ``script`` in a child Python and SIGKILLs it when it prints ``marker``."""
    child = subprocess.Popen(
        [sys.executable, "-c", _CHILD_PRELUDE + textwrap.dedent(script)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + timeout
    lines = []
    try:
        for line in child.stdout:
            lines.append(line.strip())
            if line.strip() == marker:
                child.send_signal(signal.SIGKILL)
                break
            assert time.monotonic() < deadline, "child too slow"
        child.wait(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        errors = child.stderr.read()
        child.stdout.close()
        child.stderr.close()
    assert child.returncode == -signal.SIGKILL, (lines, errors)
    return child


def _hidden(folder: Path) -> list:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def _small_map(seed: int, n: int = 4) -> nightloc.ReferenceMap:
    rng = np.random.default_rng(seed)
    return nightloc.ReferenceMap(rng.integers(0, 256, (n, 24, 48), dtype=np.uint8), rng.uniform(0, 9, (n, 2)))


def test_map_save_killed_half_way_keeps_the_previous_map(tmp_path):
    target = tmp_path / "garden.map"
    previous = _small_map(0)
    previous.save(target)
    before = target.read_bytes()
    _run_until(
        f"""
        class Reporting:  # the real temporary file, written in 256 KiB pieces with progress reports
            def __init__(self, stream, total):
                self.stream, self.total, self.written = stream, total, 0
            def write(self, data):
                view = memoryview(data).cast("B")
                for start in range(0, len(view), 1 << 18):
                    piece = view[start:start + (1 << 18)]
                    self.stream.write(piece)
                    self.written += len(piece)
                    if self.written > self.total // 2:
                        self.stream.flush()
                        wait_for_the_kill()
                return len(view)
            def __getattr__(self, name):
                return getattr(self.stream, name)

        real_atomic_file = _atomic.atomic_file
        @contextlib.contextmanager
        def reporting_atomic_file(path, mode="wb", **options):
            with real_atomic_file(path, mode, **options) as stream:
                yield Reporting(stream, 20000 * 24 * 48)

        map_file.atomic_file = reporting_atomic_file
        rng = np.random.default_rng(1)
        images = rng.integers(0, 256, (20000, 24, 48), dtype=np.uint8)
        big = nightloc.ReferenceMap(images, rng.uniform(0, 9, (20000, 2)))
        big.save({str(target)!r}, overwrite=True)
        say("saved")
        """,
        "waiting",
    )
    assert target.read_bytes() == before
    assert nightloc.ReferenceMap.load(target) == previous
    partial = [tmp_path / name for name in _hidden(tmp_path) if name.endswith(".partial")]
    assert len(partial) == 1  # (and the killed writer's lock file, released by its death)
    assert 20000 * 24 * 48 // 2 < partial[0].stat().st_size < 20000 * 24 * 48  # killed mid-way
    with pytest.raises(MapFormatError):
        nightloc.ReferenceMap.load(partial[0])  # the fragment is refused, not half-read
    _small_map(2).save(target, overwrite=True)  # the next save works despite the leftover
    assert nightloc.ReferenceMap.load(target) == _small_map(2)
    assert _hidden(tmp_path) == [], "the next save of the same map removes the killed save's leftovers"


def test_map_save_killed_before_the_rename_keeps_the_previous_map(tmp_path):
    target = tmp_path / "garden.map"
    previous = _small_map(0)
    previous.save(target)
    _run_until(
        f"""
        real_replace = os.replace
        def replace_after_a_kill(source, destination):
            wait_for_the_kill()
        os.replace = replace_after_a_kill
        _small_map = nightloc.ReferenceMap(np.zeros((3, 24, 48), np.uint8), np.zeros((3, 2)))
        _small_map.save({str(target)!r}, overwrite=True)
        """,
        "waiting",
    )
    assert nightloc.ReferenceMap.load(target) == previous


def _saved_traverse(root: Path, n: int, seed: int) -> nightloc.Traverse:
    frames = random_frames(n, seed)
    return nightloc.save_traverse(root, frames, np.arange(2 * n, dtype=float).reshape(n, 2), overwrite=True)


def _folder_bytes(root: Path) -> dict:
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("kill_point", ["half of the images", "before the swap"])
def test_traverse_overwrite_killed_keeps_the_previous_traverse(tmp_path, kill_point):
    target = tmp_path / "day"
    _saved_traverse(target, 3, seed=0)
    before = _folder_bytes(target)
    if kill_point == "half of the images":
        patch = """
        real_write = traverse.write_image_file
        def write_and_report(file, image, index):
            real_write(file, image, index)
            if index == 20:
                wait_for_the_kill()
        traverse.write_image_file = write_and_report
        """
    else:
        patch = """
        def swap_after_a_kill(staging, target, keep_previous=False):
            wait_for_the_kill()
        _atomic.replace_folder = swap_after_a_kill
        """
    _run_until(
        patch
        + f"""
        frames = [np.full((30, 60, 3), i, np.uint8) for i in range(40)]
        nightloc.save_traverse({str(target)!r}, frames, np.zeros((40, 2)), overwrite=True)
        """,
        "waiting",
    )
    assert _folder_bytes(target) == before
    loaded = nightloc.load_traverse(target)
    assert len(loaded) == 3 and loaded.read(2).shape == (30, 60, 3)
    # the next save replaces the traverse (the leftover staging folder does not get in the way)
    _saved_traverse(target, 5, seed=1)
    assert len(nightloc.load_traverse(target)) == 5
    assert _hidden(tmp_path) == [], "the next save removes the killed save's staging folder and lock file"


def test_folder_swap_is_atomic_where_the_system_allows(tmp_path):
    """replace_folder on Linux swaps the two folders in one step (no moment without a target)."""
    from nightloc.io import atomic as _atomic

    old, new = tmp_path / "old", tmp_path / "new"
    old.mkdir()
    new.mkdir()
    (old / "a").write_text("old")
    (new / "b").write_text("new")
    swapped = _atomic._exchange(new, old)
    if not swapped:
        pytest.skip("renameat2(RENAME_EXCHANGE) is not available here; the two-rename fallback is used")
    assert (old / "b").read_text() == "new" and (new / "a").read_text() == "old"


def test_map_saves_killed_at_random_times_never_leave_a_bad_map(tmp_path):
    """A child saves maps A and B in turn as fast as it can; killed at random moments, the file
    on disk is always exactly A or exactly B."""
    target = tmp_path / "map.map"
    maps = {"A": _small_map(10, 3000), "B": _small_map(11, 3000)}
    maps["A"].save(target)
    rng = np.random.default_rng(0)
    for _ in range(3):
        child = subprocess.Popen(
            [
                sys.executable,
                "-c",
                _CHILD_PRELUDE
                + textwrap.dedent(
                    f"""
                    def small_map(seed, n):  # as _small_map in the test
                        rng = np.random.default_rng(seed)
                        return nightloc.ReferenceMap(rng.integers(0, 256, (n, 24, 48), dtype=np.uint8),
                                                     rng.uniform(0, 9, (n, 2)))
                    maps = [small_map(10, 3000), small_map(11, 3000)]
                    say("ready")
                    for i in range(100000):
                        maps[i % 2].save({str(target)!r}, overwrite=True)
                    """
                ),
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        assert child.stdout.readline().strip() == "ready"
        time.sleep(float(rng.uniform(0.02, 0.4)))
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
        child.stdout.close()
        loaded = nightloc.ReferenceMap.load(target)
        assert loaded == maps["A"] or loaded == maps["B"]


# --------------------------------------------------------------------------------------------
# checksums


def test_every_damaged_byte_is_refused_or_harmless(tmp_path):
    """Flipping any single byte of a map file either makes loading fail with MapFormatError or
    changes nothing that matters (zip timestamps and the like): never a different map."""
    good = nightloc.ReferenceMap(
        np.random.default_rng(5).integers(0, 256, (6, 24, 48), dtype=np.uint8),
        np.random.default_rng(6).uniform(0, 9, (6, 2)),
        np.random.default_rng(7).uniform(-3, 3, 6),
        names=[f"f{i}.png" for i in range(6)],
    )
    data = good.save(tmp_path / "good.map").read_bytes()
    damaged = tmp_path / "damaged.map"
    refused = accepted = 0
    # about 1500 positions spread over the whole file (the header, every array, the zip records)
    for position in range(0, len(data), max(5, len(data) // 1500)):
        changed = bytearray(data)
        changed[position] ^= 0x5A
        damaged.write_bytes(bytes(changed))
        try:
            loaded = nightloc.ReferenceMap.load(damaged)
        except MapFormatError:
            refused += 1
        else:
            assert loaded == good and loaded.source == good.source, f"byte {position} changed the map silently"
            accepted += 1
    assert refused > 0.9 * (refused + accepted)


def test_array_replaced_inside_the_archive_is_caught_by_the_checksum(tmp_path):
    """A well-formed archive whose positions were edited (valid zip CRCs) fails the SHA-256."""
    good = _small_map(3)
    path = good.save(tmp_path / "m.map")
    with np.load(path) as archive:
        members = {name: archive[name] for name in archive.files}
    members["positions"] = members["positions"] + 1.0
    with open(path, "wb") as stream:
        np.savez(stream, **members)
    with pytest.raises(MapFormatError, match="checksum of 'positions'"):
        nightloc.ReferenceMap.load(path)
    header = json.loads(members["header"].tobytes())
    assert set(header["checksums"]) == {"images", "positions", *FILTER_ARRAYS}
