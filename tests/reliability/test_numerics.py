"""Numerical edge cases at the matching level: constant, all-black and saturated frames, and
identical references, on every SIMD path and thread count.

Tie-breaking (documented in docs/design.md): among equal scores the lowest reference index wins;
among equal shifts of one reference the one listed first in ``shifts`` wins (the lowest shift
by default). It must not depend on the SIMD path, the number of threads or how the references
are split between threads.
"""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc import route

import oracle

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize

P = nightloc.PreparationParams


def _periodic_panorama(period: int = 12, seed: int = 0) -> np.ndarray:
    """A 24x48 image whose columns repeat every ``period``: shifts k and k+period tie exactly."""
    tile = np.random.default_rng(seed).integers(0, 256, (24, period), dtype=np.uint8)
    return np.ascontiguousarray(np.tile(tile, (1, 48 // period)))


@pytest.mark.parametrize("threads", [1, 2])
def test_constant_images_tie_to_reference_0_and_the_first_shift(simd_path, threads):
    levels = np.array([0, 1, 77, 128, 254, 255], np.uint8)
    refs = nightloc.patch_normalize(np.broadcast_to(levels[:, None, None], (6, 24, 48)).copy())
    assert (refs == 128).all()  # a flat window is z = 0, never NaN
    query = nightloc.patch_normalize(np.full((24, 48), 3, np.uint8))
    result = nightloc.match(query, refs, threads=threads)
    assert result.index == 0 and result.score == 0.0
    assert (result.scores == 0).all() and (result.shifts == 0).all() and (result.headings == 0).all()
    shifts = [17, 3, 40]
    scores, best = nightloc.difference_matrix(np.stack([query] * 3), refs, shifts=shifts, threads=threads)
    assert (scores == 0).all() and (best == 17).all()  # the first listed shift, not the lowest


@pytest.mark.parametrize("threads", [1, 2])
def test_identical_references_tie_to_the_lowest_index(simd_path, threads):
    rng = np.random.default_rng(3)
    refs = nightloc.patch_normalize(rng.integers(0, 256, (3000, 24, 48), dtype=np.uint8))
    place = refs[2500].copy()
    for index in (2999, 2500, 1700, 40):  # the same place four times, in different thread chunks
        refs[index] = place
    query = np.roll(place, 5, axis=1)
    result = nightloc.match(query, refs, threads=threads)
    assert (result.index, result.shift, result.score) == (40, 5, 0.0)
    assert (result.scores[[40, 1700, 2500, 2999]] == 0).all()
    expected_scores, expected_shifts = oracle.difference_matrix(query[None], refs[:64], np.arange(48))
    np.testing.assert_array_equal(result.scores[:64], expected_scores[0])
    np.testing.assert_array_equal(result.shifts[:64], expected_shifts[0])
    scores, best = nightloc.difference_matrix(np.stack([query, place]), refs, threads=threads)
    assert int(np.argmin(scores[0])) == 40 and int(np.argmin(scores[1])) == 40
    assert best[0, 40] == 5 and best[1, 40] == 0


def test_periodic_panorama_ties_to_the_first_listed_shift(simd_path):
    image = _periodic_panorama()
    refs = np.stack([image, np.roll(image, 7, axis=1)])
    result = nightloc.match(image, refs)
    assert result.shifts.tolist() == [0, 5]  # 0/12/24/36 tie; 41 - 36 = 5 is the lowest of 5/17/29/41
    listed = [36, 12, 24, 0, 41, 5]
    result = nightloc.match(image, refs, shifts=listed)
    assert result.shifts.tolist() == [36, 41]
    expected_scores, expected_shifts = oracle.difference_matrix(image[None], refs, np.array(listed))
    np.testing.assert_array_equal(result.shifts, expected_shifts[0])
    np.testing.assert_array_equal(result.scores, expected_scores[0])


def _night_frames() -> dict:
    rng = np.random.default_rng(9)
    noise = rng.integers(0, 3, (480, 640, 3), dtype=np.uint8)  # the darkest night: 0..2 grey levels
    one_light = np.zeros((480, 640, 3), np.uint8)
    one_light[200:204, 300:304] = 255
    half_saturated = np.zeros((480, 640, 3), np.uint8)
    half_saturated[:, 320:] = 255
    return {
        "all black": np.zeros((480, 640, 3), np.uint8),
        "all white": np.full((480, 640, 3), 255, np.uint8),
        "sensor noise in the dark": noise,
        "one light in the dark": one_light,
        "half saturated": half_saturated,
        "16-bit black": np.zeros((480, 640), np.uint16),
        "16-bit saturated": np.full((480, 640), 65535, np.uint16),
        "one pixel": np.full((1, 1, 3), 200, np.uint8),
    }


NIGHT = _night_frames()


@pytest.mark.parametrize("equalize", ["global", "clahe", "none"])
@pytest.mark.parametrize("name", list(NIGHT))
def test_dark_and_saturated_frames_prepare_and_match_deterministically(name, equalize):
    params = P(equalize=equalize)
    frame = NIGHT[name]
    prepared = nightloc.prepare(frame, params)
    assert prepared.dtype == np.uint8 and prepared.shape == (24, 48)
    np.testing.assert_array_equal(prepared, nightloc.prepare(frame.copy(), params))
    if name in ("all black", "all white", "16-bit black", "16-bit saturated", "one pixel"):
        assert (prepared == 128).all()  # a flat frame stays flat: z = 0 everywhere
    day = nightloc.prepare(np.random.default_rng(4).integers(0, 256, (20, 96, 192, 3), dtype=np.uint8), params)
    result = nightloc.match(prepared, day)
    assert np.isfinite(result.scores).all() and np.isfinite(result.headings).all()
    expected_scores, expected_shifts = oracle.difference_matrix(prepared[None], day, np.arange(48))
    np.testing.assert_array_equal(result.scores, expected_scores[0])
    np.testing.assert_array_equal(result.shifts, expected_shifts[0])
    assert result.index == int(np.argmin(expected_scores[0]))


def test_flat_map_and_flat_query_through_the_reference_map():
    """A map of identical (flat) places and a black night frame: place 0, heading 0, score 0."""
    flat = nightloc.ReferenceMap(np.full((5, 24, 48), 128, np.uint8), np.arange(10.0).reshape(5, 2))
    result = flat.match(NIGHT["all black"])
    assert (result.index, result.shift, result.score) == (0, 0, 0.0)


def test_route_mode_on_flat_frames_never_accepts_a_nan_score():
    """Constant frames make OpenSeqSLAM's contrast enhancement 0/0 = NaN; the route localizer
    keeps running and never reports such a frame as an accepted match."""
    rng = np.random.default_rng(0)
    refs = rng.integers(0, 256, (30, 24, 48), dtype=np.uint8)
    flat = np.full((30, 24, 48), 128, np.uint8)
    for reference, queries in ((refs, flat), (flat, refs), (flat, flat)):
        localizer = route.RouteLocalizer(reference, prepared=True)
        for frame in queries[:15]:
            update = localizer.update(frame, prepared=True)
            assert update.ref is None or 0 <= update.ref < 30
            if np.isnan(update.score):
                assert not update.accepted(1e9)
        batch = route.match_prepared(reference, queries[:15])
        assert ((batch.refs >= -1) & (batch.refs < 30)).all()


# --------------------------------------------------------------------------------------------
# 2D localization on awkward reference layouts: the interpolation must still answer


def _layout_map(positions) -> nightloc.ReferenceMap:
    positions = np.asarray(positions, dtype=float)
    images = nightloc.patch_normalize(
        np.random.default_rng(8).integers(0, 256, (len(positions), 24, 48), dtype=np.uint8)
    )
    return nightloc.ReferenceMap(images, positions, np.zeros(len(positions)))


_SCATTER = np.random.default_rng(2).uniform(0, 5, (30, 2))
_LINE = np.column_stack([np.arange(8) * 0.5, np.full(8, 3.0)])
LAYOUTS = {
    "one reference": [[1.0, 2.0]],
    "two references": [[0.0, 0.0], [2.0, 1.0]],
    "collinear along x": _LINE,
    "collinear along y": _LINE[:, ::-1],
    "collinear diagonal": np.column_stack([np.arange(8) * 0.5, np.arange(8) * 0.5 + 1.0]),
    "nearly collinear (GPS jitter)": _LINE
    + np.column_stack([np.zeros(8), np.random.default_rng(3).normal(0, 1e-4, 8)]),
    "coincident pairs": [[0.0, 0.0], [0.0, 0.0], [1.0, 1.0], [1.0, 1.0], [2.0, 0.0]],
    "all at one place": [[2.0, 2.0]] * 4,
    "within a micrometre": [[0.0, 0.0], [1e-6, 0.0], [0.0, 1e-6], [1e-6, 1e-6]],
}
#: The same scattered map moved far from the origin (UTM eastings and northings are ~5e5, ~5e6 m)
FAR_AWAY = {"UTM coordinates": (500000.0, 5000000.0), "far from the origin": (5e6, 1e7)}


@pytest.mark.parametrize("interpolation", [True, False], ids=["interpolation", "nearest"])
@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_localizer_answers_on_awkward_layouts(layout, interpolation):
    """A night frame equal to reference i must be placed at reference i (within one grid cell)
    on every layout: flat heat maps (one place), lines, slivers thinner than a cell."""
    ref_map = _layout_map(LAYOUTS[layout])
    localizer = nightloc.Localizer(ref_map, method="paper", seq_len=1, interpolation=interpolation)
    cell = float(np.hypot(localizer.grid.dx, localizer.grid.dy))
    for i, image in enumerate(ref_map.images):
        estimate = localizer.update(image, prepared=True)
        assert np.isfinite([estimate.x, estimate.y]).all()
        error = float(np.hypot(*(estimate.position - ref_map.positions[i])))
        assert error <= 1.01 * cell, f"reference {i}: {error:.3g} m off (a cell is {cell:.3g} m)"
        # the reference reported stands at reference i's place (or closer to it than a cell)
        assert np.hypot(*(ref_map.positions[estimate.ref_index] - ref_map.positions[i])) <= cell


@pytest.mark.parametrize("interpolation", [True, False], ids=["interpolation", "nearest"])
@pytest.mark.parametrize("offset", list(FAR_AWAY.values()), ids=list(FAR_AWAY))
def test_localizer_far_from_the_origin_equals_the_map_at_the_origin(offset, interpolation):
    """Moving the whole map (and so the truth) by an offset moves every estimate by exactly that
    offset, to well under a millimetre: no precision is lost to large coordinates."""
    near = nightloc.Localizer(_layout_map(_SCATTER), method="paper", seq_len=3, interpolation=interpolation)
    far = nightloc.Localizer(_layout_map(_SCATTER + offset), method="paper", seq_len=3, interpolation=interpolation)
    images = near.ref_map.images
    for i in (0, 8, 17, 29, 3, 12):
        odometry = None if i == 0 else (0.1, -0.2)
        a = near.update(images[i], odometry, prepared=True)
        b = far.update(images[i], odometry, prepared=True)
        np.testing.assert_allclose(b.position - offset, a.position, atol=1e-4)
        assert a.ref_index == b.ref_index and a.frames == b.frames


@pytest.mark.parametrize("layout", ["collinear along x", "two references", "nearly collinear (GPS jitter)"])
def test_localizer_sequences_on_awkward_layouts(layout):
    """Sequences along the references, with exact odometry, end at the last reference."""
    ref_map = _layout_map(LAYOUTS[layout])
    localizer = nightloc.Localizer(ref_map, method="paper", seq_len=5)
    positions = ref_map.positions
    for i, image in enumerate(ref_map.images):
        odometry = None if i == 0 else tuple(positions[i] - positions[i - 1])
        estimate = localizer.update(image, odometry, prepared=True)
    cell = float(np.hypot(localizer.grid.dx, localizer.grid.dy))
    assert np.hypot(*(estimate.position - positions[-1])) <= 1.01 * cell


@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_filter_answers_on_awkward_layouts(layout):
    """The Bayes filter, from nothing, given one frame equal to reference i: its estimate lies at
    reference i's place (within the estimate window of two cells) on every layout, with a finite
    credible radius; a single place carries no position (the estimate is the grid's centre, the
    place itself)."""
    ref_map = _layout_map(LAYOUTS[layout])
    localizer = nightloc.Localizer(ref_map)
    cell = float(np.hypot(localizer.grid.dx, localizer.grid.dy))
    for i, image in enumerate(ref_map.images):
        localizer.reset()
        estimate = localizer.update(image, prepared=True)
        assert np.isfinite([estimate.x, estimate.y, estimate.credible_radius]).all()
        assert 0.0 <= estimate.confidence <= 1.0
        error = float(np.hypot(*(estimate.position - ref_map.positions[i])))
        assert error <= 2.5 * cell, f"reference {i}: {error:.3g} m off (a cell is {cell:.3g} m)"


@pytest.mark.parametrize("offset", list(FAR_AWAY.values()), ids=list(FAR_AWAY))
def test_filter_far_from_the_origin_equals_the_map_at_the_origin(offset):
    near = nightloc.Localizer(_layout_map(_SCATTER))
    far = nightloc.Localizer(_layout_map(_SCATTER + offset))
    images = near.ref_map.images
    for i in (0, 8, 17, 29, 3, 12):
        odometry = None if i == 0 else nightloc.RobotMotion(0.2, 0.0, 0.3)
        a = near.update(images[i], odometry, prepared=True)
        b = far.update(images[i], odometry, prepared=True)
        np.testing.assert_allclose(b.position - offset, a.position, atol=1e-4)
        assert a.ref_index == b.ref_index and a.heading == pytest.approx(b.heading, abs=1e-9)
        assert a.credible_radius == pytest.approx(b.credible_radius, abs=1e-4)
