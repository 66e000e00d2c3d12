"""Per-frame cost of the grid Bayes filter against the paper's update and against matching.

The issue's case: a 50-image map, the 100 x 100 grid, 48 heading bins (480 000 cells), one
thread, wheel odometry (``RobotMotion``) with the default noise (Table III model 1) and with
model 3 (wider blurs: up to 55 taps per axis), per update from a prepared image and from a
640 x 320 camera frame (preparation included). In the same group: the paper's update (10-frame
sequence, prepared image), ``match`` of one prepared frame against 5 000 references (the
target: a filter update costs no more), and the filter's numpy oracle (``tests/filter_oracle.py``,
float64), whose belief is asserted equal to the core's.

    python -m pytest benchmarks/test_bench_filter.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

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
        ref_map.params.width, f.shifts, f.settings,
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
