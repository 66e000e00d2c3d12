"""2D sequence matching: translation by known shifts, fusion where the answer is known."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

from nightloc.localization.heatmap import HeatMapper
from nightloc.localization.sequence import PaddedLayout, add_translated, cumulative_offsets

from heat_oracle import fuse, translate


def _oracle(heat, sx, sy, fill):
    jj, ii = np.mgrid[0 : heat.shape[0], 0 : heat.shape[1]]
    return map_coordinates(heat, [jj - sy, ii - sx], order=1, mode="grid-constant", cval=fill)


def test_integer_shifts_move_content_exactly_and_fill_from_outside():
    heat = np.arange(20.0).reshape(4, 5)
    out = translate(heat, (2, 1), fill=-1.0)
    expected = np.full((4, 5), -1.0)
    expected[1:, 2:] = heat[:3, :3]
    np.testing.assert_array_equal(out, expected)
    out = translate(heat, (-1, -3), fill=7.0)
    expected = np.full((4, 5), 7.0)
    expected[:1, :4] = heat[3:, 1:]
    np.testing.assert_array_equal(out, expected)
    np.testing.assert_array_equal(translate(heat, (0, 0)), heat)
    np.testing.assert_array_equal(translate(heat, (5, 0), fill=3.0), np.full((4, 5), 3.0))  # no wrap-around
    np.testing.assert_array_equal(translate(heat, (0, -4), fill=3.0), np.full((4, 5), 3.0))


def test_half_cell_shift_averages_neighbours():
    heat = np.zeros((3, 4))
    heat[1, 1] = 1.0
    out = translate(heat, (0.5, 0.0))
    assert out[1, 1] == pytest.approx(0.5) and out[1, 2] == pytest.approx(0.5)
    assert out.sum() == pytest.approx(1.0)


def test_sub_cell_shifts_match_scipy_bilinear_oracle():
    rng = np.random.default_rng(0)
    for _ in range(400):
        h, w = rng.integers(1, 14, 2)
        heat = rng.normal(size=(h, w))
        sx, sy = rng.uniform(-16, 16, 2)
        if rng.random() < 0.25:
            sx = float(np.round(sx))
        fill = float(rng.normal())
        np.testing.assert_allclose(translate(heat, (sx, sy), fill), _oracle(heat, sx, sy, fill), atol=1e-12)


def test_float32_padded_accumulation_matches_oracle():
    rng = np.random.default_rng(1)
    layout = PaddedLayout(30, 40, dtype=np.float32)
    total = layout.zeros()
    expected = np.zeros((30, 40))
    for _ in range(6):
        heat = rng.random((30, 40))
        sx, sy = rng.uniform(-45, 45), rng.uniform(-35, 35)
        add_translated(layout, total, layout.pad(heat.astype(np.float32)), sx, sy)
        expected += _oracle(heat, sx, sy, 0.0)
    np.testing.assert_allclose(layout.view(total), expected, atol=1e-5)


def test_cumulative_offsets():
    steps = np.array([[1.0, 0.0], [0.0, 2.0], [-0.5, 0.5]])
    np.testing.assert_allclose(cumulative_offsets(steps), [[0.5, 2.5], [-0.5, 2.5], [-0.5, 0.5]])


def test_fuse_is_the_sum_of_translated_maps():
    rng = np.random.default_rng(2)
    heats = [rng.random((12, 15)) for _ in range(4)]
    offsets = np.array([[3.2, -1.5], [2.0, 0.25], [-0.7, 0.9], [0.0, 0.0]])
    fills = [0.1, -0.2, 0.0, 0.3]
    expected = sum(_oracle(h, sx, sy, f) for h, (sx, sy), f in zip(heats, offsets, fills))
    np.testing.assert_allclose(fuse(heats, offsets, fills), expected, atol=1e-12)
    with pytest.raises(ValueError, match="offsets"):
        fuse(heats, offsets[:2])
    with pytest.raises(ValueError, match="at least one"):
        fuse([], np.zeros((0, 2)))


def _bump(mapper, x, y, height, width=0.3):
    gx, gy = np.meshgrid(mapper.grid.xs, mapper.grid.ys)
    return height * np.exp(-((gx - x) ** 2 + (gy - y) ** 2) / (2 * width**2))


def test_fusion_finds_the_true_position_when_every_single_frame_prefers_a_decoy():
    """A robot drives a curve; each frame's heat map has a weaker bump at the true position and
    a stronger one at a random decoy. Translated by the true displacements, the true bumps pile
    up on the current position and the sequence estimate finds it; single frames never do."""
    rng = np.random.default_rng(3)
    corners = np.array([[0.0, 0.0], [8.0, 0.0], [0.0, 6.0], [8.0, 6.0]])
    mapper = HeatMapper(corners, grid_width=81, grid_height=61, margin=0.0)
    t = np.linspace(0, 1.5, 12)
    path = np.column_stack([1.0 + 5.0 * t / 1.5, 3.0 + 2.0 * np.sin(2 * t)])
    heats, singles_wrong = [], 0
    for x, y in path:
        decoy = rng.uniform([0.5, 0.5], [7.5, 5.5])
        while np.hypot(*(decoy - (x, y))) < 2.0:
            decoy = rng.uniform([0.5, 0.5], [7.5, 5.5])
        heat = _bump(mapper, x, y, 1.0) + _bump(mapper, *decoy, 1.3)
        heats.append(heat)
        single = mapper.estimate(heat)
        singles_wrong += np.hypot(single.x - x, single.y - y) > 1.0
    assert singles_wrong == len(path)
    n = 6
    wrong_without_odometry = 0
    for k in range(n - 1, len(path)):
        window = heats[k - n + 1 : k + 1]
        steps = np.diff(path[k - n + 1 : k + 1], axis=0)
        offsets = np.vstack([cumulative_offsets(steps), [0.0, 0.0]])
        fused = fuse(window, mapper.grid.to_cells(offsets))
        est = mapper.estimate(fused)
        assert np.hypot(est.x - path[k, 0], est.y - path[k, 1]) <= 0.11  # one cell diagonal
        # without the odometry (no translation) the true bumps do not line up
        still = mapper.estimate(fuse(window, np.zeros((n, 2))))
        wrong_without_odometry += np.hypot(still.x - path[k, 0], still.y - path[k, 1]) > 0.3
    assert wrong_without_odometry >= (len(path) - n + 1) // 2
