"""Per-frame cost of the grid Bayes filter against the paper's update and against matching.

The small-map case: a 50-image map, the 100 x 100 grid, 48 heading bins (480 000 cells), one
thread, wheel odometry (``RobotMotion``) with the default noise (Table III model 1) and with
model 3 (wider blurs: up to 55 taps per axis), per update from a prepared image and from a
640 x 320 camera frame (preparation included). In the same group: the paper's update (10-frame
sequence, prepared image), ``match`` of one prepared frame against 5 000 references (the
target: a filter update costs no more), and the filter's numpy oracle (``tests/filter_oracle.py``,
float64), whose belief is asserted equal to the core's.

Large maps: 5 000 and 20 000 places about 0.4 m apart (a house, a large lawn), the
default 100 x 100 grid, a robot driving from place to place (each frame the reference image of
the place it reaches, turned to its heading; exact wheel odometry, the filter told noise model
3); one group per size with ``match`` against the map's references (the target: a noise-3 update
costs at most 2x that at 5 000 places), the update in the drive's steady state, the update from
a settled belief (the robot tracked: most heading bins negligible) and the numpy oracle's step.

    python -m pytest benchmarks/test_bench_filter.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import copy
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import nightloc

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from filter_oracle import OracleFilter

N_REFS, SEQ_LEN, BIG = 50, 10, 5000
MOTION = nightloc.RobotMotion(0.12, 0.01, 0.05)
GROUP = f"per frame: filter ({N_REFS} refs, 100x100 grid, 48 bins) vs paper vs match {BIG} refs, 1 thread"


@pytest.fixture(scope="module")
def setup():
    rng = np.random.default_rng(0)
    raw = rng.integers(0, 256, (N_REFS, 96, 192), dtype=np.uint8)
    ref_map = nightloc.ReferenceMap(
        nightloc.prepare(raw), rng.uniform([0, 0], [7, 5], (N_REFS, 2)), rng.uniform(-np.pi, np.pi, N_REFS)
    )
    frame = rng.integers(0, 256, (320, 640, 3), dtype=np.uint8)
    big = nightloc.patch_normalize(rng.integers(0, 256, (BIG, 24, 48), dtype=np.uint8))
    return ref_map, frame, ref_map.preparer.prepare(frame), big


def _filter(ref_map, query, noise):
    loc = nightloc.Localizer(ref_map, odometry_noise=noise, threads=1)
    for _ in range(5):  # a belief that has seen frames (not the uniform start)
        loc.update(query, MOTION)
    return loc


@pytest.mark.parametrize("noise", [1, 3], ids=["noise 1", "noise 3"])
def test_filter_update_prepared_image(benchmark, setup, noise):
    ref_map, _, query, _ = setup
    loc = _filter(ref_map, query, noise)
    benchmark.group = GROUP
    est = benchmark(loc.update, query, MOTION)
    assert est.method == "filter" and np.isfinite(est.credible_radius)


def test_filter_update_camera_frame(benchmark, setup):
    ref_map, frame, query, _ = setup
    loc = _filter(ref_map, query, 1)
    benchmark.group = GROUP
    est = benchmark(loc.update, frame, MOTION)
    assert est.method == "filter"


def test_paper_update_prepared_image(benchmark, setup):
    ref_map, _, query, _ = setup
    loc = nightloc.Localizer(ref_map, method="paper", seq_len=SEQ_LEN, threads=1)
    for _ in range(SEQ_LEN):
        loc.update(query, (0.12, 0.05))
    benchmark.group = GROUP
    est = benchmark(loc.update, query, (0.12, 0.05))
    assert est.frames == SEQ_LEN


def test_match_against_5000_references(benchmark, setup):
    _, _, query, big = setup
    benchmark.group = GROUP
    result = benchmark(nightloc.match, query, big, threads=1)
    assert result.scores.shape == (BIG,)


def test_numpy_oracle_step(benchmark, setup):
    ref_map, _, query, _ = setup
    loc = nightloc.Localizer(ref_map, odometry_noise=1, threads=1)
    mapper, f = loc.mapper, loc._filter
    grid = mapper.grid
    place = np.empty(mapper.n_refs, dtype=int)
    for p, members in enumerate(mapper._members):
        place[members] = p
    oracle = OracleFilter(
        mapper.weights, grid.height, grid.width, grid.x0, grid.y0, grid.dx, grid.dy, place, ref_map.headings,
        ref_map.params.width, f.shifts, f.settings.to_dict(),
    )  # fmt: skip
    table = nightloc.rotational_sad(query, ref_map.images)
    loc.update_table(table)
    oracle.update(table)

    steps = []

    def step():
        oracle.predict_robot(MOTION.forward, MOTION.left, MOTION.turn)
        oracle.update(table)
        steps.append(1)
        return oracle.estimate()

    benchmark.group = GROUP
    benchmark.pedantic(step, rounds=3, iterations=1)
    for _ in steps:  # the core, the same steps (once with --benchmark-disable)
        loc.update_table(table, MOTION)
    want = oracle.p / oracle.p.sum()
    assert np.abs(loc.pose_belief - want).max() <= 1e-4 * want.max()


# ----------------------------------------------------------------------------------------------
# large maps

SPACING = 0.4  # metres between places


def _drive(n_places, seed=0):
    """A map of ``n_places`` random panoramas on a jittered lattice and a robot driving through them
    row by row: ``frame(k)`` is its k-th query (the reference image of place k + 1 turned to the
    robot's heading) and the exact wheel odometry from place k."""
    rng = np.random.default_rng(seed)
    side = math.ceil(math.sqrt(n_places))
    row, column = np.divmod(np.arange(n_places), side)
    column = np.where(row % 2 == 0, column, side - 1 - column)  # a serpentine: place k + 1 is next
    positions = np.column_stack([column, row]) * SPACING + rng.uniform(-0.05, 0.05, (n_places, 2))
    headings = rng.uniform(-np.pi, np.pi, n_places)
    images = nightloc.patch_normalize(rng.integers(0, 256, (n_places, 24, 48), dtype=np.uint8))
    ref_map = nightloc.ReferenceMap(images, positions, headings)
    steps = np.diff(positions, axis=0)
    theta = np.arctan2(steps[:, 1], steps[:, 0])

    def frame(k):
        k %= n_places - 1
        turn = 0.0 if k == 0 else float(np.angle(np.exp(1j * (theta[k] - theta[k - 1]))))
        shift = round((theta[k] - headings[k + 1]) * 48 / (2 * np.pi))
        motion = nightloc.RobotMotion(float(np.hypot(*steps[k])), 0.0, turn)
        return np.roll(images[k + 1], shift, axis=1), motion

    frame.heading = lambda k: float(theta[k % (n_places - 1)])  # the robot's heading at frame k
    return ref_map, frame


@pytest.fixture(scope="module", params=[5000, 20000], ids=["5000 places", "20000 places"])
def drive(request):
    n = request.param
    ref_map, frame = _drive(n)
    steady = nightloc.Localizer(ref_map, odometry_noise=3, threads=1)
    for k in range(30):  # the drive's steady state under noise model 3
        steady.update(*frame(k))
    # a robot being tracked: its belief concentrated at its pose (what frames that agree make of
    # it; from a uniform start that takes tens of frames on these maps of look-alike places)
    tracked = steady.fresh()  # the same grid and weights
    tracked.update(*frame(60))
    grid, (x, y), heading = tracked.grid, ref_map.positions[61], frame.heading(60)
    gx, gy = np.meshgrid(grid.xs, grid.ys)
    belief = np.full((48, grid.height, grid.width), 1e-9)
    belief[round(heading / (2 * np.pi / 48)) % 48] += np.exp(-((gx - x) ** 2 + (gy - y) ** 2) / (2 * 0.3**2))
    tracked._filter.core.set_belief(belief.astype(np.float32), True, 0.0)
    tracked.update(*frame(61))
    return n, ref_map, frame, steady, tracked


def _group(n):
    return f"per frame, {n} places {SPACING} m apart (100x100 grid, 48 bins): filter noise 3 vs match, 1 thread"


def test_large_map_match(benchmark, drive):
    n, ref_map, frame, _, _ = drive
    query, _ = frame(100)
    benchmark.group = _group(n)
    result = benchmark(nightloc.match, query, ref_map.images, threads=1)
    assert result.scores.shape == (n,)


def test_large_map_update_steady(benchmark, drive):
    n, _, frame, steady, _ = drive
    loc = copy.copy(steady)
    frames = iter(range(30, 10**9))
    benchmark.group = _group(n)
    est = benchmark(lambda: loc.update(*frame(next(frames))))
    assert est.method == "filter" and math.isfinite(est.credible_radius)


def test_large_map_update_from_a_settled_belief(benchmark, drive):
    n, _, frame, _, tracked = drive
    query, motion = frame(62)

    def setup():
        return (copy.copy(tracked),), {}

    benchmark.group = _group(n)
    est = benchmark.pedantic(lambda loc: loc.update(query, motion), setup=setup, rounds=20)
    assert est.confidence > 0.5  # the belief had settled


def test_large_map_numpy_oracle_step(benchmark, drive):
    n, ref_map, frame, steady, _ = drive
    loc = copy.copy(steady)
    mapper, f = loc.mapper, loc._filter
    grid = mapper.grid
    oracle = OracleFilter(
        mapper.weights, grid.height, grid.width, grid.x0, grid.y0, grid.dx, grid.dy, mapper.place_of_ref,
        ref_map.headings, ref_map.params.width, f.shifts, f.settings.to_dict(),
    )  # fmt: skip
    belief = loc.pose_belief  # the oracle starts from the core's belief
    oracle.p = belief.copy()
    oracle.offset = loc.heading_offset
    oracle.bin_max = belief.reshape(belief.shape[0], -1).max(axis=1)
    oracle.frames = f.core.frames  # past the tempered start
    query, motion = frame(30)
    table = nightloc.rotational_sad(query, ref_map.images)

    def step():
        oracle.predict_robot(motion.forward, motion.left, motion.turn)
        oracle.update(table)
        return oracle.estimate()

    benchmark.group = _group(n)
    benchmark.pedantic(step, rounds=1, iterations=1)
    loc.update_table(table, motion)
    want = oracle.p / oracle.p.sum()
    assert np.abs(loc.pose_belief - want).max() <= 1e-4 * want.max()
