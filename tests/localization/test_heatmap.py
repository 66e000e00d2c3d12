"""Heat maps: interpolation exactness on planar fields, outside-hull values, estimates, duplicates."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from nightloc.localization.heatmap import HeatGrid, HeatMapper, invert_scores


def _random_positions(rng, n=40, size=(7.0, 5.0)):
    return rng.uniform(0, 1, (n, 2)) * np.array(size)


def _cell_centres(mapper):
    gx, gy = np.meshgrid(mapper.grid.xs, mapper.grid.ys)
    return gx, gy


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_linear_field_is_reproduced_exactly_inside_the_hull(seed):
    rng = np.random.default_rng(seed)
    positions = _random_positions(rng)
    mapper = HeatMapper(positions, grid_width=60, grid_height=45, margin=0.3)
    a, b, c = rng.normal(size=3)
    field = a + b * positions[:, 0] + c * positions[:, 1]
    heat = mapper.interpolate(field, fill=-99.0)
    gx, gy = _cell_centres(mapper)
    expected = a + b * gx + c * gy
    # inside = Delaunay's own point location (an independent test of the hull mask)
    inside = Delaunay(positions).find_simplex(np.column_stack([gx.ravel(), gy.ravel()])).reshape(gx.shape) >= 0
    assert np.array_equal(inside, mapper.inside)
    assert 0.3 < inside.mean() < 1.0
    np.testing.assert_allclose(heat[inside], expected[inside], rtol=0, atol=1e-9)
    assert np.all(heat[~inside] == -99.0)


def test_piecewise_linear_between_three_points_matches_barycentric_formula():
    positions = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 2.0]])
    mapper = HeatMapper(positions, grid_width=41, grid_height=21, margin=0.0)
    values = np.array([1.0, 5.0, -3.0])
    heat = mapper.interpolate(values)
    # cell (x=1, y=0.5): barycentric (1 - x/4 - y/2, x/4, y/2) = (0.5, 0.25, 0.25)
    i, j = 10, 5
    assert mapper.grid.xs[i] == pytest.approx(1.0) and mapper.grid.ys[j] == pytest.approx(0.5)
    assert heat[j, i] == pytest.approx(0.5 * 1 + 0.25 * 5 + 0.25 * -3)
    assert np.isnan(heat[20, 40])  # (4, 2) is outside the triangle


def test_outside_cells_get_lowest_or_nearest_value():
    rng = np.random.default_rng(3)
    positions = _random_positions(rng, 25)
    scores = rng.uniform(10, 40, 25)
    lowest = HeatMapper(positions, grid_width=50, grid_height=40, margin=0.5)
    heat, fill = lowest.heat_map(scores)
    inverted = invert_scores(scores)
    assert fill == inverted.min() == 0.0
    assert np.all(heat[~lowest.inside] == fill)
    nearest = HeatMapper(positions, grid_width=50, grid_height=40, margin=0.5, outside="nearest")
    heat_n, _ = nearest.heat_map(scores)
    gx, gy = _cell_centres(nearest)
    cells = np.column_stack([gx.ravel(), gy.ravel()])
    closest = np.argmin(((cells[:, None, :] - positions[None]) ** 2).sum(-1), axis=1).reshape(gx.shape)
    outside = ~nearest.inside
    np.testing.assert_allclose(heat_n[outside], inverted[closest[outside]])
    np.testing.assert_allclose(heat_n[~outside], heat[~outside])


def test_inversions():
    scores = np.array([10.0, 20.0, 30.0, 20.0])
    np.testing.assert_allclose(invert_scores(scores, "range"), [1.0, 0.5, 0.0, 0.5])
    z = invert_scores(scores, "zscore")
    assert z.mean() == pytest.approx(0) and z.std() == pytest.approx(1) and z[0] > z[1] > z[2]
    np.testing.assert_allclose(invert_scores(scores, "negate"), -scores)
    np.testing.assert_allclose(invert_scores(np.full(3, 7.0)), 0.0)
    np.testing.assert_allclose(invert_scores(np.stack([scores, scores * 2])), [[1, 0.5, 0, 0.5]] * 2)
    with pytest.raises(ValueError, match="NaN"):
        invert_scores(np.array([1.0, np.nan]))
    with pytest.raises(ValueError, match="inversion"):
        invert_scores(scores, "log")


def _lattice_mapper(rng, **kwargs):
    """References on integer metres of a 6 x 4 m area; the grid's cell centres are every 0.1 m."""
    xs, ys = np.meshgrid(np.arange(7.0), np.arange(5.0))
    lattice = np.column_stack([xs.ravel(), ys.ravel()])
    keep = np.sort(np.r_[[0, 6, 28, 34], rng.choice(np.arange(1, 28), 14, replace=False)])
    positions = lattice[np.unique(keep)]
    return positions, HeatMapper(positions, grid_width=61, grid_height=41, margin=0.0, **kwargs)


@pytest.mark.parametrize("interpolation", [True, False])
def test_single_frame_estimate_is_best_reference_when_it_lies_on_a_cell(interpolation):
    rng = np.random.default_rng(4)
    positions, mapper = _lattice_mapper(rng, interpolation=interpolation)
    for _ in range(20):
        scores = rng.uniform(20, 40, len(positions))
        best = int(rng.integers(len(positions)))
        scores[best] = 5.0
        heat, _ = mapper.heat_map(scores)
        est = mapper.estimate(heat, scores)
        assert (est.x, est.y) == pytest.approx(tuple(positions[best]), abs=1e-9)
        assert est.ref_index == best
        assert est.peak == pytest.approx(1.0)


def test_interpolation_off_estimate_is_best_reference_for_any_layout():
    rng = np.random.default_rng(5)
    positions = _random_positions(rng, 30)
    mapper = HeatMapper(positions, interpolation=False)
    assert mapper.inside.all()
    for _ in range(20):
        scores = rng.uniform(0, 50, 30)
        est = mapper.estimate(mapper.heat_map(scores)[0], scores)
        assert est.ref_index == int(np.argmin(scores))
        assert (est.x, est.y) == tuple(positions[np.argmin(scores)])


def test_interpolated_estimate_moves_towards_the_second_best_neighbour():
    positions = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0], [1.0, 1.0]])
    mapper = HeatMapper(positions, grid_width=21, grid_height=21, margin=0.0)
    # equal best at (0,0) and (2,0): along that edge the linear interpolation is flat and maximal
    scores = np.array([1.0, 1.0, 9.0, 9.0, 9.0])
    est = mapper.estimate(mapper.heat_map(scores)[0], scores)
    assert est.y == pytest.approx(0.0) and 0.0 <= est.x <= 2.0


def test_duplicate_positions_take_the_best_and_report_it():
    positions = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [3.0, 3.0], [3.0, 3.0]])
    mapper = HeatMapper(positions, grid_width=31, grid_height=31, margin=0.0)
    scores = np.array([30.0, 30.0, 30.0, 25.0, 10.0])  # the second copy of (3, 3) is the best
    heat, _ = mapper.heat_map(scores)
    est = mapper.estimate(heat, scores)
    assert (est.x, est.y) == pytest.approx((3.0, 3.0)) and est.ref_index == 4
    field = np.array([0.0, 3.0, 6.0, 9.0, 9.0])  # x + 2y, consistent at the duplicate
    np.testing.assert_allclose(
        mapper.interpolate(field)[mapper.inside],
        (_cell_centres(mapper)[0] + 2 * _cell_centres(mapper)[1])[mapper.inside],
        atol=1e-9,
    )


def test_collinear_and_tiny_layouts_interpolate_along_the_line():
    positions = np.array([[0.0, 1.0], [1.0, 2.0], [3.0, 4.0]])  # on y = x + 1
    mapper = HeatMapper(positions, grid_width=31, grid_height=31, margin=0.0)
    heat = mapper.interpolate(2.0 * positions[:, 0])  # linear along the line
    gx, gy = _cell_centres(mapper)
    on_line = np.isclose(gy, gx + 1.0)
    assert mapper.inside[on_line].all()
    np.testing.assert_allclose(heat[on_line], 2.0 * gx[on_line], atol=1e-9)
    scores = np.array([9.0, 1.0, 9.0])
    assert mapper.estimate(mapper.heat_map(scores)[0], scores).ref_index == 1
    for positions in (np.array([[1.0, 1.0]]), np.array([[0.0, 0.0], [2.0, 0.0]])):
        mapper = HeatMapper(positions, grid_width=10, grid_height=10)
        est = mapper.estimate(mapper.heat_map(np.arange(len(positions), dtype=float))[0])
        assert est.ref_index == 0


def test_fast_padded_path_equals_heat_map():
    rng = np.random.default_rng(6)
    positions = _random_positions(rng, 50)
    mapper = HeatMapper(positions)
    scores = rng.uniform(5, 50, 50)
    heat, fill = mapper.heat_map(scores)
    excess, fill2 = mapper.excess(scores)
    assert fill2 == fill
    np.testing.assert_allclose(mapper.layout.view(excess) + fill, heat, atol=1e-5)
    assert np.all(excess.reshape(mapper.grid.height, -1)[:, mapper.grid.width :] == 0)


def test_confidence_one_clear_peak_versus_two_equal_places():
    positions = np.array([[0.0, 0.0], [6.0, 0.0], [0.0, 4.0], [6.0, 4.0], [3.0, 2.0]])
    mapper = HeatMapper(positions, grid_width=61, grid_height=41, margin=0.0, confidence_radius=1.0)
    clear = np.array([9.0, 9.0, 9.0, 9.0, 1.0])
    est = mapper.estimate(mapper.heat_map(clear)[0])
    # a cone falling linearly to the corners 3.6 m away: just beyond 1 m it is 1 - 1/3.6 at best
    assert est.confidence == pytest.approx(1.0 / np.hypot(3.0, 2.0), abs=0.03)
    two = np.array([1.0, 9.0, 9.0, 1.0, 9.0])  # opposite corners equally good
    est = mapper.estimate(mapper.heat_map(two)[0])
    assert est.confidence == pytest.approx(0.0, abs=1e-9)
    flat = np.full(5, 3.0)
    assert mapper.estimate(mapper.heat_map(flat)[0]).confidence == 0.0


def test_grid_geometry():
    grid = HeatGrid.spanning(np.array([[1.0, 2.0], [5.0, 4.0]]), width=5, height=3, margin=1.0)
    np.testing.assert_allclose(grid.xs, [0, 1.5, 3, 4.5, 6])
    np.testing.assert_allclose(grid.ys, [1, 3, 5])
    assert grid.extent == pytest.approx((-0.75, 6.75, 0.0, 6.0))
    assert grid.position(7) == pytest.approx((3.0, 3.0))
    np.testing.assert_allclose(grid.to_cells([3.0, -4.0]), [2.0, -2.0])
    flat = HeatGrid.spanning(np.array([[1.0, 2.0], [5.0, 2.0]]), width=5, height=3, margin=0.0)
    assert flat.dy > 0 and flat.ys.mean() == pytest.approx(2.0)


def test_bad_inputs_are_clear_errors():
    with pytest.raises(ValueError, match="positions"):
        HeatMapper(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="NaN"):
        HeatMapper(np.array([[0.0, np.nan], [1, 1], [2, 0]]))
    with pytest.raises(ValueError, match="grid width"):
        HeatMapper(np.eye(2), grid_width=1)
    with pytest.raises(ValueError, match="outside"):
        HeatMapper(np.eye(2), outside="zero")
    mapper = HeatMapper(np.array([[0.0, 0], [1, 0], [0, 1]]))
    with pytest.raises(ValueError, match="one per reference"):
        mapper.heat_map(np.zeros(4))
    with pytest.raises(ValueError, match="NaN"):
        mapper.heat_map(np.array([1.0, np.nan, 2.0]))
    with pytest.raises(ValueError, match="heat must be"):
        mapper.estimate(np.zeros((3, 3)))
