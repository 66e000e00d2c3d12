"""Build time of a teach run (the target: 2 000 images on 2 cores in at most 30 s), and
the speed of its min-warping kernel against the numpy oracle.

The drive: the large garden's perimeter pass and mowing rows, then back along the same path (a
second mowing), resampled to 2 000 frames (0.45 m apart), rendered at 96x48 (prepared to 48x24 as
any camera), with the wheel-noise odometry of :data:`nightloc.synth.dataset.SYNTH_WHEEL_NOISE`.
Timed: ``teach_run`` on the folder (reading and preparing the frames, every frame against every
other, the candidates, four rounds of the pose graph, the marginals), two threads. ``extra_info`` holds the frames, the
visual constraints and the ATE against the true poses.

    python -m pytest benchmarks/test_bench_teach.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gtsam")

import nightloc
from nightloc.mapping import TeachWarning, absolute_trajectory_error, teach_run
from nightloc.synth import Camera, SynthScene, plan_traverses
from nightloc.synth.dataset import SYNTH_WHEEL_NOISE

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import warp_oracle

FRAMES = 2000


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    day = plan_traverses("large_garden")[0]
    path = np.concatenate([day.positions, day.positions[::-1][1:]])
    turned = np.unwrap(np.concatenate([day.headings, day.headings[::-1][1:] + np.pi]))
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    where = np.linspace(0.0, travelled[-1], FRAMES)
    positions = np.column_stack([np.interp(where, travelled, path[:, k]) for k in range(2)])
    headings = np.interp(where, travelled, turned)
    headings = np.pi - np.mod(np.pi - headings, 2 * np.pi)
    scene = SynthScene("large_garden", seed=0, camera=Camera(96, 48))
    frames = [
        scene.frame("day", x, y, h, scene.frame_rng("bench", k))
        for k, ((x, y), h) in enumerate(zip(positions, headings))
    ]
    odometry = SYNTH_WHEEL_NOISE.simulate(positions, headings, np.random.default_rng(20))
    folder = tmp_path_factory.mktemp("teach") / "drive"
    return nightloc.save_traverse(folder, frames, positions, headings, odometry=odometry)


@pytest.mark.slow
def test_teach_run_2000_frames(benchmark, drive):
    benchmark.group = f"teach run: {FRAMES} frames, 2 threads"

    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TeachWarning)
            return teach_run(drive, teach=None, threads=2)

    teach_map, report = benchmark.pedantic(run, rounds=1, iterations=1)
    ate = absolute_trajectory_error(teach_map.positions, drive.positions)
    reckoned = absolute_trajectory_error(report.dead_reckoning[:, :2], drive.positions)
    benchmark.extra_info.update(
        frames=FRAMES, accepted=report.accepted, ate_m=round(ate, 3), dead_reckoning_m=round(reckoned, 3)
    )
    assert len(teach_map) == FRAMES and teach_map.pose_source == "optimised"
    assert ate < 0.5 * reckoned


@pytest.fixture(scope="module")
def warp_case():
    """16 pairs of 48x24 panoramas of the living room's day drive, the teach run's window (17
    directions x 9 shifts), with the default tables."""
    from nightloc.mapping.warping import PanoramaWarper

    from synth_support import default_synth_data

    images = nightloc.Preparer().prepare(nightloc.load_traverse(default_synth_data()["living_room"]["day_reference"]))
    warper = PanoramaWarper(images, threads=1)
    rng = np.random.default_rng(4)
    pairs = rng.integers(0, len(images), (16, 2))
    return warper, pairs, rng.integers(0, len(warper.directions), 16), rng.integers(0, 48, 16)


@pytest.mark.parametrize("implementation", ["numpy", "core"])
def test_warp_costs(benchmark, warp_case, implementation):
    """Min-warping costs of 16 pairs (one thread): the core against its numpy oracle."""
    warper, pairs, first_direction, first_shift = warp_case
    benchmark.group = "min-warping: 16 pairs of 48x24 panoramas, 17 directions x 9 shifts"
    if implementation == "core":
        out = benchmark(warper.costs, pairs, first_direction, 17, first_shift, 9)
    else:
        tables = (warper.images, warper.stacks, warper.row_begin, warper.row_end, warper.level, warper.sign)
        out = benchmark(warp_oracle.warp_costs, *tables, pairs, first_direction, 17, first_shift, 9)
    assert out.shape == (16, 17, 9) and np.isfinite(out).all()
