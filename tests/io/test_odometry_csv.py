"""odometry.csv: written by save_traverse and synth, read back per traverse frame (composed over
skipped frames), with clear errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nightloc
from nightloc.errors import DatasetError
from nightloc.io.odometry_csv import read_odometry_rows, write_odometry_csv
from nightloc.motion.odometry import (
    MapDisplacement,
    RobotMotion,
    compose_motions,
    read_odometry,
    traverse_odometry,
    true_robot_motions,
)


def _images(n):
    return (np.full((8, 16), 10 * k, np.uint8) for k in range(n))


def test_save_traverse_writes_wheel_odometry_that_reads_back(tmp_path):
    rng = np.random.default_rng(0)
    positions = np.cumsum(rng.normal(0, 0.3, (6, 2)), axis=0)
    headings = rng.uniform(-3, 3, 6)
    motions = true_robot_motions(positions, headings)
    traverse = nightloc.save_traverse(tmp_path / "t", _images(6), positions, headings, odometry=motions)
    assert (traverse.root / "odometry.csv").read_text().splitlines()[0] == "image,forward,left,turn"
    back = traverse_odometry(traverse)
    assert back[0] is None
    for got, want in zip(back[1:], motions[1:]):
        assert (got.forward, got.left, got.turn) == pytest.approx((want.forward, want.left, want.turn), abs=1e-12)
    # a traverse folder with odometry.csv is still a traverse: overwrite replaces it
    nightloc.save_traverse(tmp_path / "t", _images(6), positions, headings, odometry=motions, overwrite=True)


def test_skipped_frames_are_composed_into_the_next_kept_one(tmp_path):
    rng = np.random.default_rng(1)
    positions = np.cumsum(rng.normal(0, 0.3, (9, 2)), axis=0)
    headings = rng.uniform(-3, 3, 9)
    motions = true_robot_motions(positions, headings)
    nightloc.save_traverse(tmp_path / "t", _images(9), positions, headings, odometry=motions)
    every_third = nightloc.load_traverse(tmp_path / "t", frame_step=3)
    composed = traverse_odometry(every_third)
    exact = true_robot_motions(every_third.positions, every_third.headings)
    for got, want in zip(composed[1:], exact[1:]):
        assert got.forward == pytest.approx(want.forward, abs=1e-9)
        assert got.left == pytest.approx(want.left, abs=1e-9)
        assert math.remainder(got.turn - want.turn, 2 * math.pi) == pytest.approx(0, abs=1e-9)
    assert compose_motions([MapDisplacement(1, 2), MapDisplacement(-0.5, 0.5)]) == MapDisplacement(0.5, 2.5)
    with pytest.raises(ValueError, match="compose"):
        compose_motions([MapDisplacement(1, 2), RobotMotion(1)])


def test_video_logs_key_rows_by_frame(tmp_path):
    file = write_odometry_csv(tmp_path / "o.csv", [0, 1, 2], [None, (0.1, 0.0), (0.2, 0.1)], key_column="frame")
    rows, form = read_odometry_rows(file, "frame")
    assert form == "map" and [r[0] for r in rows] == [0, 1, 2]
    motion = read_odometry(file, [0, 2], "frame")[1]
    assert (motion.dx, motion.dy) == pytest.approx((0.3, 0.1))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("image,a,b\nx.png,1,2\n", "neither forward,left,turn"),
        ("frame,dx,dy\n0,1,2\n", "missing column 'image'"),
        ("image,dx,dy\na.png,1,nan\n", "finite"),
        ("image,dx,dy\na.png,1,x\n", "not a number"),
        ("image,dx,dy\na.png,1,2\na.png,1,2\n", "listed twice"),
        ("image,dx,dy\n", "no odometry rows"),
        ("image,dx,dy\nb.png,1,2\n", "no row for image 'a.png'"),
        ("image,dx,dy\nb.png,1,2\na.png,1,2\n", "order"),
    ],
)
def test_bad_odometry_files_name_file_line_and_fix(tmp_path, text, message):
    file = tmp_path / "odometry.csv"
    file.write_text(text)
    with pytest.raises(DatasetError, match=message):
        read_odometry(file, ["a.png", "b.png"])


def test_save_traverse_rejects_bad_odometry_before_writing(tmp_path):
    with pytest.raises(TypeError, match="odometry"):
        nightloc.save_traverse(tmp_path / "t", _images(2), odometry="abc")
    with pytest.raises(ValueError, match="all wheel odometry"):
        nightloc.save_traverse(tmp_path / "t", _images(2), odometry=[RobotMotion(1), (0.1, 0.2)])
    with pytest.raises(ValueError, match="2 positions"):
        nightloc.save_traverse(tmp_path / "t", _images(2), np.zeros((2, 2)), odometry=[None, None, None])
    with pytest.raises(ValueError, match="odometry rows but 2 images"):
        nightloc.save_traverse(tmp_path / "t", _images(2), odometry=[None])
    assert not (tmp_path / "t").exists()


def test_synth_writes_realistic_wheel_odometry():
    """Every synthetic drive's odometry.csv is the wheel-noise model applied to the true motions:
    the same draw again from the traverse's own generator, and not the exact motions."""
    from nightloc.motion.wheel_noise import WheelNoise
    from nightloc.synth import SynthScene

    from synth_support import default_synth_data

    folder = default_synth_data()["garden"]["night_query"]
    traverse = nightloc.load_traverse(folder)
    motions = traverse_odometry(traverse)
    expected = WheelNoise().simulate(
        traverse.positions, traverse.headings, SynthScene("garden").odometry_rng("night_query")
    )
    exact = true_robot_motions(traverse.positions, traverse.headings)
    for got, want in zip(motions[1:], expected[1:]):
        assert (got.forward, got.left, got.turn) == pytest.approx((want.forward, want.left, want.turn), abs=1e-12)
    turn_error = np.array([m.turn - e.turn for m, e in zip(motions[1:], exact[1:])])
    assert 0.02 < turn_error.std() < 0.1  # N(0, 0.05 rad) per step
