"""Per-frame cost of the streaming 2D localizer (target: <= 1 ms on one core).

The small-map case: a 50-image map, the 100 x 100 grid, 10-frame sequences, one 640 x 320 BGR
camera frame per update (preparation included), map-frame odometry. The group also times the
update from a prepared image and from a match result, and a plain scipy formulation of the
same heat-map work (``griddata`` per frame, ``map_coordinates`` per earlier frame) that
rebuilds the triangulation every frame; its fused map is asserted equal to the localizer's.

A second group times the sequence sum alone (9 earlier 100 x 100 maps translated and added to
the current one): the OpenCV three-pass formulation (:func:`add_translated_opencv`), the
compiled kernel called per map (:func:`add_translated`) and the localizer's compiled sequence
(``HeatSequence.fuse_peak``: the sum, the peak and the runner-up in one call).

    python -m pytest benchmarks/test_bench_localizer.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import griddata
from scipy.ndimage import map_coordinates

import nightloc
from nightloc.localization.heatmap import invert_scores
from nightloc.localization.sequence import add_translated, cumulative_offsets

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from heat_oracle import add_translated_opencv, scratch

N_REFS, SEQ_LEN, STEP = 50, 10, (0.12, 0.05)
GROUP = f"localizer update: {N_REFS} refs, 100x100 grid, n={SEQ_LEN}"


@pytest.fixture(scope="module")
def setup():
    rng = np.random.default_rng(0)
    raw = rng.integers(0, 256, (N_REFS, 96, 192), dtype=np.uint8)
    ref_map = nightloc.ReferenceMap(
        nightloc.prepare(raw), rng.uniform([0, 0], [7, 5], (N_REFS, 2)), rng.uniform(-np.pi, np.pi, N_REFS)
    )
    frame = rng.integers(0, 256, (320, 640, 3), dtype=np.uint8)
    return ref_map, frame


def _warm(ref_map, frame, prepared=False):
    loc = nightloc.Localizer(ref_map, method="paper", seq_len=SEQ_LEN, threads=1)
    query = ref_map.preparer.prepare(frame) if prepared else frame
    for _ in range(SEQ_LEN):
        loc.update(query, STEP)
    return loc, query


def test_update_camera_frame(benchmark, setup):
    ref_map, frame = setup
    loc, _ = _warm(ref_map, frame)
    benchmark.group = GROUP
    est = benchmark(loc.update, frame, STEP)
    assert est.frames == SEQ_LEN


def test_update_prepared_image(benchmark, setup):
    ref_map, frame = setup
    loc, query = _warm(ref_map, frame, prepared=True)
    benchmark.group = GROUP
    est = benchmark(loc.update, query, STEP)
    assert est.frames == SEQ_LEN


def test_update_from_match_result(benchmark, setup):
    ref_map, frame = setup
    loc, query = _warm(ref_map, frame, prepared=True)
    result = nightloc.match(query, ref_map.images, threads=1)
    benchmark.group = GROUP
    est = benchmark(loc.update_match, result, STEP)
    assert est.frames == SEQ_LEN


def scipy_fused_heat_map(positions, scores_per_frame, steps, grid_x, grid_y):
    """Plain scipy: interpolate every frame (new triangulation each time), shift, sum."""
    gx, gy = np.meshgrid(grid_x, grid_y)
    dx, dy = grid_x[1] - grid_x[0], grid_y[1] - grid_y[0]
    offsets = np.vstack([cumulative_offsets(np.asarray(steps[1:])), [0.0, 0.0]])
    jj, ii = np.mgrid[0 : len(grid_y), 0 : len(grid_x)]
    total = np.zeros(gx.shape)
    for scores, (ox, oy) in zip(scores_per_frame, offsets):
        inverted = invert_scores(scores)
        heat = griddata(positions, inverted, (gx, gy), method="linear", fill_value=inverted.min())
        total += map_coordinates(heat, [jj - oy / dy, ii - ox / dx], order=1, mode="grid-constant", cval=inverted.min())
    return total


def test_scipy_formulation(benchmark, setup):
    ref_map, frame = setup
    loc, query = _warm(ref_map, frame, prepared=True)
    result = nightloc.match(query, ref_map.images, threads=1)
    scores = [np.asarray(result.scores, dtype=np.float64)] * SEQ_LEN
    steps = [STEP] * SEQ_LEN
    benchmark.group = GROUP
    fused = benchmark(scipy_fused_heat_map, ref_map.positions, scores, steps, loc.grid.xs, loc.grid.ys)
    est = loc.update_match(result, STEP, return_heatmap=True)
    np.testing.assert_allclose(est.heatmap, fused, atol=1e-4)


SUM_GROUP = f"sum of {SEQ_LEN} translated 100x100 heat maps (float32)"


@pytest.fixture(scope="module")
def sequence_maps(setup):
    """The localizer's grid, its sequence after SEQ_LEN frames, and the same maps as padded buffers."""
    ref_map, _ = setup
    loc = nightloc.Localizer(ref_map, method="paper", seq_len=SEQ_LEN, threads=1)
    rng = np.random.default_rng(5)
    mapper = loc.mapper
    sequence = mapper.sequence(SEQ_LEN)
    layout = mapper.layout
    padded = []
    for _ in range(SEQ_LEN):
        values, fill = mapper.place_excess(rng.uniform(5, 40, N_REFS))
        sequence.push(values, fill)
        padded.append(layout.pad(sequence.frame(-1)))
    steps = np.tile(STEP, (SEQ_LEN - 1, 1))
    offsets = np.ascontiguousarray(loc.grid.to_cells(cumulative_offsets(steps)))
    return layout, sequence, padded, offsets


def _sum_with(translate, layout, padded, offsets):
    total = padded[-1].copy()
    for source, (sx, sy) in zip(padded[:-1], offsets):
        translate(layout, total, source, float(sx), float(sy))
    return layout.view(total)


_WORK_BUFFERS: dict = {}


def _opencv_passes(layout, out, source, shift_x, shift_y):
    """The OpenCV three-pass oracle with a work buffer kept across calls (as the core needs none)."""
    buffer = _WORK_BUFFERS.get(layout.size)
    if buffer is None:
        buffer = _WORK_BUFFERS[layout.size] = scratch(layout)
    add_translated_opencv(layout, out, source, shift_x, shift_y, buffer)


@pytest.mark.parametrize("method", ["opencv passes", "core per map"])
def test_sequence_sum_per_map(benchmark, sequence_maps, method):
    layout, sequence, padded, offsets = sequence_maps
    translate = _opencv_passes if method == "opencv passes" else add_translated
    benchmark.group = SUM_GROUP
    got = benchmark(_sum_with, translate, layout, padded, offsets)
    sequence.fuse_peak(offsets)
    np.testing.assert_allclose(got, sequence.fused(), atol=1e-5)


def test_sequence_sum_core_sequence(benchmark, sequence_maps):
    layout, sequence, padded, offsets = sequence_maps
    benchmark.group = SUM_GROUP
    benchmark(sequence.fuse_peak, offsets)
    np.testing.assert_allclose(sequence.fused(), _sum_with(_opencv_passes, layout, padded, offsets), atol=1e-5)
