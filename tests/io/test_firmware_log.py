"""``write_firmware_log`` (nightloc export-log): a log rewritten as the firmware replay reads it.

The oracle is the log itself: the written frames decode to the pixels nightloc decodes from the
original, the rows hold the motions ``traverse_odometry`` gives, and times and poses are kept.
"""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc.errors import DatasetError
from nightloc.io.firmware_log import FIRMWARE_FRAME_SUFFIXES, firmware_frame_names, write_firmware_log
from nightloc.io.images import read_image_file
from nightloc.motion.odometry import RobotMotion, traverse_odometry

from video_support import write_video


def frames(n: int, colour: bool, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 256, (12, 20, 3) if colour else (12, 20), dtype=np.uint8) for _ in range(n)]


def a_log(folder, n=6, colour=True, names=None, timestamps=None, poses=True, images=None):
    motions = [RobotMotion(0.1 * k, 0.01, 0.02 * k) for k in range(n)]
    positions = np.column_stack([np.arange(n) * 0.3, np.zeros(n)]) if poses else None
    return nightloc.save_traverse(
        folder,
        images if images is not None else frames(n, colour),
        positions,
        np.zeros(n) if poses else None,
        names,
        odometry=motions,
        timestamps=timestamps,
    )


def tree(folder):
    return {
        str(p.relative_to(folder)): (p.read_bytes(), p.stat().st_mtime_ns) for p in folder.rglob("*") if p.is_file()
    }


@pytest.mark.parametrize("colour", [False, True], ids=["grey", "colour"])
def test_frames_rows_times_and_poses_are_the_logs(tmp_path, colour):
    log = a_log(tmp_path / "log", colour=colour, timestamps=np.arange(6) * 0.1 + 5)
    before = tree(log.root)
    written = write_firmware_log(log, tmp_path / "out", traverse_odometry(log))
    assert tree(log.root) == before
    suffix = FIRMWARE_FRAME_SUFFIXES[3 if colour else 1]
    assert written.names == tuple(f"{k:06d}{suffix}" for k in range(6))  # 000003.png -> 000003.ppm
    for k in range(6):
        assert (written.path(k).read_bytes()[:2] == b"P6") == colour
        np.testing.assert_array_equal(read_image_file(written.path(k)), log.read(k))
    assert traverse_odometry(written) == traverse_odometry(log)
    np.testing.assert_array_equal(written.timestamps, log.timestamps)
    np.testing.assert_array_equal(written.positions, log.positions)
    np.testing.assert_array_equal(written.headings, log.headings)


def test_rows_between_kept_frames_are_composed_as_localize_uses_them(tmp_path):
    log = nightloc.load_traverse(a_log(tmp_path / "log", n=9).root, frame_step=3)
    motions = traverse_odometry(log)
    written = write_firmware_log(log, tmp_path / "out", motions)
    assert len(written) == 3 and traverse_odometry(written) == motions


def test_a_video_log_gets_its_frame_labels_as_names(tmp_path):
    video = tmp_path / "drive.avi"
    write_video(video, 5)
    odometry = tmp_path / "odometry.csv"
    odometry.write_text("frame,dx,dy\n" + "".join(f"{k},0.{k},0\n" for k in range(5)))
    log = nightloc.load_traverse(video)
    written = write_firmware_log(log, tmp_path / "out", traverse_odometry(log, odometry))
    assert written.names == tuple(f"frame_{k:06d}.ppm" for k in range(5))
    assert traverse_odometry(written) == traverse_odometry(log, odometry)


@pytest.mark.parametrize(
    ("names", "expected"),
    [
        (["a2.png", "a10.jpg", "b.bmp"], ["a2.pgm", "a10.pgm", "b.pgm"]),  # natural order kept
        (["b.png", "a.png"], ["000000.pgm", "000001.pgm"]),  # poses.csv's order is not the names'
        (["x.png", "x.jpg"], ["000000.pgm", "000001.pgm"]),  # the same name twice
        (["a,1.png", "a,2.png"], ["000000.pgm", "000001.pgm"]),  # a comma: not a plain CSV cell
    ],
)
def test_names_sort_in_frame_order_or_are_numbered(names, expected):
    assert firmware_frame_names(names, ".pgm") == expected


def test_a_16_bit_frame_writes_nothing_and_removes_the_parents_it_made(tmp_path):
    images = frames(6, colour=False)
    images[4] = images[4].astype(np.uint16) * 257
    log = a_log(tmp_path / "log", images=images)
    with pytest.raises(DatasetError, match=r"frame '000004.png' of .* is 16-bit: the firmware prepares 8-bit"):
        write_firmware_log(log, tmp_path / "new" / "out", traverse_odometry(log))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log"]


def test_grey_and_colour_frames_mixed_are_refused(tmp_path):
    images = frames(6, colour=True)
    images[2] = images[2][..., 0].copy()
    log = a_log(tmp_path / "log", images=images)
    with pytest.raises(DatasetError, match=r"frame '000002\.png' .* is grey but the first frame is not"):
        write_firmware_log(log, tmp_path / "out", traverse_odometry(log))
    assert not (tmp_path / "out").exists()


def test_an_existing_log_is_replaced_only_when_asked(tmp_path):
    log = a_log(tmp_path / "log")
    out = tmp_path / "out"
    write_firmware_log(log, out, traverse_odometry(log))
    with pytest.raises(FileExistsError, match="exists"):
        write_firmware_log(log, out, traverse_odometry(log))
    write_firmware_log(log, out, traverse_odometry(log), overwrite=True)
    notes = tmp_path / "notes"
    notes.mkdir()
    (notes / "todo.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="not a traverse folder"):
        write_firmware_log(log, notes, traverse_odometry(log), overwrite=True)
    assert (notes / "todo.txt").read_text() == "mine"


def test_one_motion_per_frame(tmp_path):
    log = a_log(tmp_path / "log")
    with pytest.raises(ValueError, match="5 odometry motions for the 6 frames"):
        write_firmware_log(log, tmp_path / "out", traverse_odometry(log)[:5])
