"""Min-warping: relative heading and direction of travel of panoramas taken apart, against
renders at known poses (the synthetic living room's near walls) and the geometry it assumes."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nightloc
import warp_oracle
from gil_support import python_runs_during
from nightloc.mapping.visual import relative_heading
from nightloc.mapping.warping import PanoramaWarper, WarpParams
from nightloc.synth import SynthScene

from synth_support import default_synth_data


def _angle(a: float) -> float:
    return abs(math.remainder(a, 2 * math.pi))


def test_direction_tables_follow_the_triangle():
    """Each allowed move of a column is a landmark at a distance >= b / max_parallax, seen
    magnified by the sine rule's ratio (to the scales' spacing)."""
    params = WarpParams()
    warper = PanoramaWarper(np.zeros((1, 24, 48), np.uint8), params)
    alphas, level, sign = warper.directions, warper.level, warper.sign
    step = 2 * math.pi / 48
    log_spacing = math.log(warper.scales[1] / warper.scales[0])
    checked = 0
    for g in range(0, len(alphas), 7):
        for c in range(48):
            theta = float(np.remainder(-step * c - alphas[g] + math.pi, 2 * math.pi) - math.pi)
            off = abs(theta)
            assert sign[g, c] == (1 if theta >= 0 else -1)
            if level[g, c, 0] == len(warper.scales):  # on the axis: any scale, no move
                assert min(off, math.pi - off) < math.radians(params.axis_degrees) + 1e-9
                continue
            for m in np.flatnonzero(level[g, c] >= 0):
                moved = off + m * step
                if m > 0:  # the landmark's distance from A, in units of the baseline
                    distance = math.sin(moved) / math.sin(moved - off)
                    assert distance >= 1 / params.max_parallax - 1e-9
                magnification = math.sin(moved) / math.sin(off)
                expected = np.clip(math.log(magnification) / log_spacing + (len(warper.scales) - 1) / 2, 0, 12)
                assert abs(level[g, c, m] - expected) <= 0.5 + 1e-9
                checked += 1
    assert checked > 1000


@pytest.fixture(scope="module")
def room():
    return SynthScene("living_room", seed=0)


def _frame(scene, x, y, heading, name):
    return nightloc.prepare(scene.frame("day", x, y, heading, scene.frame_rng(name, 0)))


def test_pure_rotation(room):
    """One place at two headings: the heading is the turn, whatever direction is assumed."""
    turn = math.radians(-47.0)
    images = np.stack([_frame(room, 3.0, 1.5, 0.2, "a"), _frame(room, 3.0, 1.5, 0.2 + turn, "b")])
    warper = PanoramaWarper(images)
    for direction in (0.0, 1.0, None):
        measured = warper.measure(0, 1, direction, math.radians(30), turn + 0.05, 4)
        assert _angle(measured.heading - turn) < math.radians(1.5)


@pytest.fixture(scope="module")
def living_room_day():
    return nightloc.load_traverse(default_synth_data()["living_room"]["day_reference"])


def test_rows_a_metre_apart_by_near_walls(living_room_day):
    """The living room's day drive, frames of neighbouring rows 1 m apart (walls 0.5-2 m away),
    from an estimate a little off (relative heading 2.3 degrees, direction 9 degrees): warping
    keeps the relative heading to 2.5 degrees (median) and finds the direction of travel; the
    columns along the line between the two places err more than twice as much (their
    neighbours see the near walls move)."""
    positions = np.asarray(living_room_day.positions)
    headings = np.asarray(living_room_day.headings)
    images = nightloc.Preparer().prepare(living_room_day)
    warper = PanoramaWarper(images)
    warp_errors, axis_errors, direction_errors = [], [], []
    for i in range(len(images)):
        for j in range(i + 4, len(images)):
            offset = positions[j] - positions[i]
            if not (abs(abs(offset[1]) - 1.0) < 0.05 and abs(offset[0]) <= 0.5):
                continue
            turn = headings[j] - headings[i]
            direction = math.atan2(offset[1], offset[0]) - headings[i]
            sign = (-1) ** (i + j)
            prior, guess = turn + 0.04 * sign, direction + 0.15 * sign
            measured = warper.measure(i, j, guess, math.radians(30), prior, 4)
            warp_errors.append(_angle(measured.heading - turn))
            direction_errors.append(_angle(measured.direction - direction))
            axis, _ = relative_heading(images[j], images[i], guess, prior=prior)
            axis_errors.append(_angle(axis - turn))
    assert len(warp_errors) >= 60
    assert np.median(warp_errors) < math.radians(2.5) and np.percentile(warp_errors, 90) < math.radians(6.0)
    assert np.median(direction_errors) < math.radians(8.0)
    assert np.median(axis_errors) > 2 * np.median(warp_errors)


def test_bad_input():
    with pytest.raises(ValueError, match="uint8"):
        PanoramaWarper(np.zeros((2, 24, 48), np.float32))
    with pytest.raises(ValueError, match="elevation"):
        WarpParams(elevation_top=-10.0, elevation_bottom=10.0)
    with pytest.raises(ValueError, match="max_parallax"):
        WarpParams(max_parallax=0.0)


@pytest.mark.sanitize
def test_core_costs_match_the_numpy_oracle(living_room_day):
    """The compiled costs are the numpy oracle's bit for bit (real frames, the default tables,
    windows wrapping round both ends, every direction and shift for one pair), on 1 and 2
    threads."""
    images = nightloc.Preparer().prepare(living_room_day)[:8]
    warper = PanoramaWarper(images, threads=1)
    tables = (warper.images, warper.stacks, warper.row_begin, warper.row_end, warper.level, warper.sign)
    pairs = np.array([[0, 5], [3, 1], [7, 7], [2, 6]])
    grid = len(warper.directions)
    for first_direction, n_directions, first_shift, n_shifts in (
        (np.array([0, 90, 40, 95]), 17, np.array([44, 0, 3, 20]), 9),
        (np.zeros(4), grid, np.zeros(4), 48),
    ):
        expected = warp_oracle.warp_costs(*tables, pairs, first_direction, n_directions, first_shift, n_shifts)
        for threads in (1, 2):
            warper.threads = threads
            got = warper.costs(pairs, first_direction, n_directions, first_shift, n_shifts)
            assert got.dtype == np.float64 and got.shape == expected.shape
            np.testing.assert_array_equal(got, expected)


@pytest.mark.sanitize
def test_core_costs_match_the_oracle_on_random_tables():
    """Random frames, stacks and tables (every level value: -1, each scale, L = any scale; an
    empty row range; odd sizes), starts out of range both ways and more shifts than columns (the
    kernel's runs of W shifts): bit for bit the oracle's, on 1 and 3 threads."""
    rng = np.random.default_rng(7)
    for height, width, scales, grid, moves in ((5, 13, 3, 7, 4), (24, 48, 4, 96, 25), (17, 31, 1, 31, 16)):
        n = 5
        images = rng.integers(0, 256, (n, height, width), dtype=np.uint8)
        stacks = rng.integers(0, 256, (n, scales, height, width), dtype=np.uint8)
        row_begin = rng.integers(0, height // 2, scales).astype(np.int32)
        row_end = np.maximum(row_begin, rng.integers(height // 2, height + 1, scales)).astype(np.int32)
        if scales > 1:
            row_end[1] = row_begin[1]  # an empty range: never compared
        level = rng.integers(-1, scales + 1, (grid, width, moves)).astype(np.int32)
        level[0] = -1  # a direction where no column may move: +inf
        sign = np.where(rng.random((grid, width)) < 0.5, 1, -1).astype(np.int32)
        pairs = rng.integers(0, n, (6, 2)).astype(np.int32)
        first_direction = rng.integers(-2 * grid, 2 * grid, 6).astype(np.int32)
        first_direction[0] = 0
        first_shift = rng.integers(-3 * width, 3 * width, 6).astype(np.int32)
        tables = (images, stacks, row_begin, row_end, level, sign)
        for n_directions, n_shifts in ((3, 2 * width + 5), (grid + 2, 7)):
            expected = warp_oracle.warp_costs(*tables, pairs, first_direction, n_directions, first_shift, n_shifts)
            assert np.isinf(expected).any() and np.isfinite(expected).any()
            for threads in (1, 3):
                got = nightloc._core.warp_costs(
                    *tables, pairs, first_direction, n_directions, first_shift, n_shifts, threads
                )
                np.testing.assert_array_equal(got, expected)


@pytest.mark.sanitize
def test_core_costs_release_the_gil():
    """While one thread scores many pairs, another keeps executing Python code (held, the main
    thread could run only before the worker re-acquires the GIL)."""
    rng = np.random.default_rng(3)
    warper = PanoramaWarper(rng.integers(0, 256, (40, 24, 48), dtype=np.uint8), threads=1)
    pairs = rng.integers(0, 40, (150, 2))
    grid = len(warper.directions)
    assert python_runs_during(lambda: warper.costs(pairs, np.zeros(150), grid, np.zeros(150), 48)) > 0.5


@pytest.mark.sanitize
def test_core_costs_bad_input():
    images = np.zeros((3, 24, 48), np.uint8)
    warper = PanoramaWarper(images)
    with pytest.raises(ValueError, match="frame index 3"):
        warper.costs(np.array([[0, 3]]), np.zeros(1), 1, np.zeros(1), 1)
    with pytest.raises(ValueError, match="n_directions"):
        warper.costs(np.array([[0, 1]]), np.zeros(1), 0, np.zeros(1), 1)
    args = [warper.images, warper.stacks, warper.row_begin, warper.row_end, warper.level, warper.sign]
    bad_level = warper.level.copy()
    bad_level[0, 0, 0] = 99
    with pytest.raises(ValueError, match="level 99"):
        nightloc._core.warp_costs(*args[:4], bad_level, args[5], np.zeros((1, 2), np.int32), np.zeros(1, np.int32), 1,
                                  np.zeros(1, np.int32), 1)  # fmt: skip
    with pytest.raises(ValueError, match="stacks must have shape"):
        nightloc._core.warp_costs(args[0], args[1][:2], *args[2:], np.zeros((1, 2), np.int32), np.zeros(1, np.int32), 1,
                                  np.zeros(1, np.int32), 1)  # fmt: skip
    with pytest.raises(TypeError, match="int32"):
        nightloc._core.warp_costs(*args, np.zeros((1, 2), np.int64), np.zeros(1, np.int32), 1, np.zeros(1, np.int32), 1)
