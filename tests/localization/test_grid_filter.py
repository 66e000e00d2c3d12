"""The grid Bayes filter (Localizer(method="filter")): the compiled core against its numpy oracle on
random maps and motions, identical results on every SIMD path, the edge cases (ties, NaN, frames
off the map, one or two references, no headings, forward cameras), kidnapping, uncertainty and
the API's errors."""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np
import pytest

import nightloc
from filter_oracle import OracleFilter
from nightloc.localization.grid_filter import FilterParams
from nightloc.localization.localizer import Localizer
from nightloc.matching.sad import shift_table
from nightloc.motion.odometry import MapDisplacement, NoiseModel, RobotMotion, wrap_angle

# Tolerances against the float64 oracle: the core keeps float32 beliefs and sums 50-tap kernels
# in float, so beliefs agree to ~1e-6 of their maximum per step; over a few steps 1e-4 leaves room.
BELIEF_RTOL = 1e-4
POSITION_TOL = 1e-4  # metres


def _random_map(rng, n=12, headings=True, width=16, height=8, area=(4.0, 3.0), shifts_all=True):
    positions = rng.uniform(0, area, (n, 2))
    head = rng.uniform(-np.pi, np.pi, n) if headings else None
    images = rng.integers(0, 256, (n, height, width), dtype=np.uint8)
    params = nightloc.PreparationParams(width=width, height=height, wrap=shifts_all)
    return nightloc.ReferenceMap(images, positions, head, params=params)


def _oracle(loc: Localizer) -> OracleFilter:
    f, m = loc._filter, loc.mapper
    g = m.grid
    place = np.empty(m.n_refs, dtype=int)
    for p, members in enumerate(m._members):
        place[members] = p
    return OracleFilter(
        m.weights, g.height, g.width, g.x0, g.y0, g.dx, g.dy, place, loc.ref_map.headings,
        loc.ref_map.params.width, f.shifts, f.settings.to_dict(), f.field_of_view, f.window[0], f.learned,
    )  # fmt: skip


def _apply(oracle: OracleFilter, motion) -> None:
    if motion is None:
        oracle.predict_unknown()
    elif isinstance(motion, RobotMotion):
        oracle.predict_robot(motion.forward, motion.left, motion.turn)
    else:
        oracle.predict_map(motion.dx, motion.dy)


def _check_against_oracle(loc, oracle, estimate):
    got = loc.pose_belief
    want = oracle.p / oracle.p.sum()
    assert got.shape == want.shape
    assert np.abs(got - want).max() <= BELIEF_RTOL * want.max()
    x, y, heading, cov, radius, confidence, _cell, _flat, heading_var = oracle.estimate()
    marginal = oracle.marginal().ravel()
    top2 = np.sort(marginal)[-2:]
    if top2[1] - top2[0] > 1e-3 * top2[1]:  # a clear peak: the same cell, the same refinement
        assert (estimate.x, estimate.y) == pytest.approx((x, y), abs=POSITION_TOL)
        if math.isfinite(heading):
            assert wrap_angle(estimate.heading - heading) == pytest.approx(0.0, abs=1e-4)
        assert estimate.confidence == pytest.approx(confidence, abs=1e-4)
        # the radius is a cell-centre distance: it may step to the next ring within rounding
        assert abs(estimate.credible_radius - radius) <= 1.5 * math.hypot(oracle.dx, oracle.dy)
    np.testing.assert_allclose(estimate.covariance, cov, rtol=1e-3, atol=1e-6)
    if math.isfinite(heading_var):
        assert estimate.heading_variance == pytest.approx(heading_var, rel=1e-3, abs=1e-6)
    else:
        assert math.isnan(estimate.heading_variance)


MOTIONS = [
    None,
    RobotMotion(0.31, 0.05, 0.4),
    RobotMotion(-0.2, 0.0, -1.3),
    MapDisplacement(0.15, -0.27),
    None,  # unknown motion: spread wide
    RobotMotion(0.5, 0.1, 7.0),
    RobotMotion(0.0, 0.0, 0.05),
    MapDisplacement(0.0, 0.0),
]


def _drive_beside_oracle(loc: Localizer, rng, columns: int = 16) -> list:
    """Drives ``loc`` and its numpy oracle through :data:`MOTIONS` with random score tables of
    ``columns`` columns, checking them against each other after every frame; the estimates."""
    oracle = _oracle(loc)
    estimates = []
    for k, motion in enumerate(MOTIONS):
        table = rng.uniform(15, 25, (len(loc.ref_map), columns)).astype(np.float32)
        estimate = loc.update_table(table, motion if k else None)
        if k:
            _apply(oracle, motion)
        oracle.update(table)
        _check_against_oracle(loc, oracle, estimate)
        estimates.append(estimate)
    return estimates


@pytest.mark.sanitize  # drives the core (CI runs it again under ASan + UBSan)
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("noise", [0, 3, NoiseModel(0.05, 0.3), NoiseModel(0.02, 0.05, 0.3, 0.4)])
def test_core_equals_the_numpy_oracle_on_random_maps_and_motions(seed, noise):
    rng = np.random.default_rng(seed)
    ref_map = _random_map(rng, n=int(rng.integers(3, 16)))
    loc = Localizer(ref_map, odometry_noise=noise, grid_width=int(rng.integers(20, 45)), grid_height=30)
    estimates = _drive_beside_oracle(loc, rng)
    assert [e.frames for e in estimates] == list(range(1, len(MOTIONS) + 1))
    assert all(e.method == "filter" for e in estimates)


@pytest.mark.sanitize
@pytest.mark.parametrize("seed", [0, 1])
def test_core_equals_the_numpy_oracle_on_an_experience_map(seed):
    # learned references whose scores run lower than the day ones, as a night frame's do against
    # night looks: two looks at one place, looks taken at other headings than the day images', and
    # a look learned in a gap (no day image at its position); the core moves their evidence onto
    # their places' day references
    from nightloc.io.appearances import Appearances, LearnedNight

    rng = np.random.default_rng(seed)
    day = _random_map(rng, n=9)
    looks = rng.choice(9, 5, replace=False)
    looks = np.r_[looks, looks[0]]  # two looks at one place
    gap = np.array([[day.positions[:, 0].max() + 1.0, day.positions[:, 1].mean()]])
    n_learned = len(looks) + 1
    night = np.r_[np.zeros(9, np.int32), np.ones(n_learned, np.int32)]
    appearances = Appearances(
        night=night, confidence=np.where(night > 0, 0.9, 0.0), time=np.zeros(len(night)),
        matches=np.zeros(len(night), np.int64),
        nights=(LearnedNight(1, "night1", "2026-01-01T00:00:00Z", 5, 5, 5, 1, 0),),
    )  # fmt: skip
    turned = rng.uniform(-0.3, 0.3, len(looks))  # the learning night's headings, not the day's
    ref_map = nightloc.ReferenceMap(
        np.concatenate([day.images, day.images[looks], day.images[:1]]),
        np.concatenate([day.positions, day.positions[looks], gap]),
        np.concatenate([day.headings, wrap_angle(day.headings[looks] + turned), [0.2]]),
        params=day.params,
        appearances=appearances,
    )
    loc = Localizer(ref_map, odometry_noise=1, grid_width=30, grid_height=24)
    np.testing.assert_array_equal(loc._filter.learned, night > 0)
    oracle = _oracle(loc)
    assert (oracle.proxy[9:-1] == looks).all() and oracle.proxy[-1] == -1
    for k, motion in enumerate(MOTIONS):
        table = rng.uniform(15, 25, (len(ref_map), 16)).astype(np.float32)
        table[9:] *= 0.4  # night looks: lower scores everywhere
        estimate = loc.update_table(table, motion if k else None)
        if k:
            _apply(oracle, motion)
        oracle.update(table)
        _check_against_oracle(loc, oracle, estimate)
        assert estimate.score == pytest.approx(float(oracle.mins.min()), rel=1e-6)


@pytest.mark.sanitize
def test_core_equals_the_numpy_oracle_recalling_the_looks_near_the_belief():
    # three looks at each of 8 places of a 9-place map: 24 looks, more than the 9 day references,
    # so each frame recalls the 9 looks nearest the last belief's peak
    from nightloc.io.appearances import Appearances, LearnedNight

    rng = np.random.default_rng(3)
    day = _random_map(rng, n=9)
    looks = np.repeat(np.arange(8), 3)
    night = np.r_[np.zeros(9, np.int32), np.ones(len(looks), np.int32)]
    appearances = Appearances(
        night=night, confidence=np.where(night > 0, 0.9, 0.0), time=np.zeros(len(night)),
        matches=np.zeros(len(night), np.int64),
        nights=(LearnedNight(1, "night1", "2026-01-01T00:00:00Z", 24, 24, 24, 0, 0),),
    )  # fmt: skip
    ref_map = nightloc.ReferenceMap(
        np.concatenate([day.images, day.images[looks]]),
        np.concatenate([day.positions, day.positions[looks]]),
        np.concatenate([day.headings, day.headings[looks] + rng.uniform(-0.2, 0.2, len(looks))]),
        params=day.params,
        appearances=appearances,
    )
    loc = Localizer(ref_map, odometry_noise=1, grid_width=30, grid_height=24)
    oracle = _oracle(loc)
    recalls = []
    for k, motion in enumerate(MOTIONS):
        table = rng.uniform(15, 25, (len(ref_map), 16)).astype(np.float32)
        table[1] -= 8.0  # the day image of place 1 matches: the belief peaks there
        table[9:] *= rng.uniform(0.3, 0.5, (len(looks), 1)).astype(np.float32)
        if k:
            _apply(oracle, motion)
        recalls.append(oracle.recalled())
        estimate = loc.update_table(table, motion if k else None)
        oracle.update(table)
        _check_against_oracle(loc, oracle, estimate)
    assert all(r.sum() == 9 + 9 for r in recalls)  # the day references and 9 of the 24 looks
    assert len({tuple(r) for r in recalls}) > 1  # the recall followed the belief
    # update_image matches only the recalled references and scores the rest as their day
    # references: the same estimate as the whole table gives
    image = rng.integers(0, 256, (8, 16), dtype=np.uint8)
    a, b = copy.copy(loc), copy.copy(loc)
    from_image = a.update(image, MOTIONS[1])
    from_table = b.update_table(b.score_table(image, prepared=True), MOTIONS[1])
    assert (from_image.x, from_image.y, from_image.confidence) == pytest.approx(
        (from_table.x, from_table.y, from_table.confidence), abs=1e-9
    )


def test_the_estimate_of_a_given_belief_is_the_oracles():
    # a smoother's product of two runs' beliefs, estimated as the filter estimates its own
    rng = np.random.default_rng(7)
    ref_map = _random_map(rng, n=10)
    loc = Localizer(ref_map, odometry_noise=1, grid_width=30, grid_height=24)
    oracle = _oracle(loc)
    for k, motion in enumerate(MOTIONS[:3]):
        loc.update_table(rng.uniform(10, 20, (10, 16)).astype(np.float32), motion if k else None)
    belief = loc.belief * rng.uniform(0.5, 1.5, loc.belief.shape)  # any positive scale
    estimate = loc.estimate_belief(belief * 3.0)
    oracle.pose, oracle.p = False, (belief / belief.sum())[None]
    x, y, _, _, radius, confidence, _, _, heading_var = oracle.estimate()
    assert (estimate.x, estimate.y) == pytest.approx((x, y), abs=1e-4)
    assert estimate.heading_variance == pytest.approx(heading_var, nan_ok=True)
    assert estimate.credible_radius == pytest.approx(radius, abs=1e-6)
    assert estimate.confidence == pytest.approx(confidence, abs=1e-5)
    assert estimate.best_ref == -1 and math.isnan(estimate.score)
    np.testing.assert_allclose(loc.belief, belief / belief.sum(), rtol=1e-5)  # the filter now holds it
    with pytest.raises(ValueError, match="grid_height, grid_width"):
        loc.estimate_belief(belief[:5])
    with pytest.raises(ValueError, match="non-negative"):
        loc.estimate_belief(-belief)


def test_step_scaled_noise_is_the_constant_noise_of_each_step():
    # wheel odometry's step-scaled model blurs a step as the constant model of that step's size:
    # distance_per_metre |(forward, left)| and heading_per_radian |turn| in quadrature
    rng = np.random.default_rng(5)
    ref_map = _random_map(rng, n=10)
    scaled = NoiseModel(0.01, 0.03, 0.2, 0.3)
    a = Localizer(ref_map, odometry_noise=scaled, grid_width=30, grid_height=24)
    b = Localizer(ref_map, odometry_noise=0, grid_width=30, grid_height=24)
    motions = [None, RobotMotion(0.4, 0.1, 0.3), RobotMotion(1.2, 0.0, -1.1), RobotMotion(0.0, 0.0, 0.0)]
    for k, motion in enumerate(motions):
        table = rng.uniform(15, 25, (len(ref_map), 16)).astype(np.float32)
        if motion is not None:
            b.noise = NoiseModel(
                math.hypot(scaled.distance_std, scaled.distance_per_metre * math.hypot(motion.forward, motion.left)),
                math.hypot(scaled.heading_std, scaled.heading_per_radian * motion.turn),
            )
        a.update_table(table, motion if k else None)
        b.update_table(table, motion if k else None)
        np.testing.assert_allclose(a.pose_belief, b.pose_belief, rtol=1e-6, atol=1e-6 * b.pose_belief.max())
    # and a long step is blurred more than the constant model alone would: the beliefs differ
    c = Localizer(ref_map, odometry_noise=NoiseModel(0.01, 0.03), grid_width=30, grid_height=24)
    a.reset()
    for k, motion in enumerate(motions[:3]):
        table = rng.uniform(15, 25, (len(ref_map), 16)).astype(np.float32)
        a.update_table(table, motion if k else None)
        c.update_table(table, motion if k else None)
    assert np.abs(a.pose_belief - c.pose_belief).max() > 1e-3 * c.pose_belief.max()


def test_position_only_maps_equal_the_oracle():
    rng = np.random.default_rng(7)
    ref_map = _random_map(rng, n=9, headings=False)
    loc = Localizer(ref_map, odometry_noise=2, grid_width=33, grid_height=27)
    oracle = _oracle(loc)
    assert not loc._filter.can_pose
    for k, motion in enumerate([None, MapDisplacement(0.4, 0.1), None, MapDisplacement(-1.0, 0.5)]):
        table = rng.uniform(15, 25, (9, 16)).astype(np.float32)
        estimate = loc.update_table(table, motion)
        if k:
            _apply(oracle, motion)
        oracle.update(table)
        _check_against_oracle(loc, oracle, estimate)
        assert math.isnan(estimate.heading)  # no map headings


def test_every_simd_path_gives_the_same_beliefs_and_estimates():
    rng = np.random.default_rng(11)
    ref_map = _random_map(rng, n=10)
    tables = rng.uniform(15, 25, (len(MOTIONS), 10, 16)).astype(np.float32)
    runs = {}
    for path in nightloc.available_simd_backends():
        with nightloc.use_simd_backend(path):
            loc = Localizer(ref_map, odometry_noise=2, grid_width=37, grid_height=23)
            out = []
            for k, motion in enumerate(MOTIONS):
                e = loc.update_table(tables[k], motion if k else None)
                out.append((e.x, e.y, e.heading, e.credible_radius, e.confidence, loc.pose_belief.copy()))
            runs[path] = out
    reference = runs["scalar"]
    for path, out in runs.items():
        for a, b in zip(reference, out):
            assert a[:5] == pytest.approx(b[:5], abs=0, rel=0, nan_ok=True), path
            assert np.array_equal(a[5], b[5]), path


def _many_place_map(rng, n=420, width=16, height=8):
    """More places than fit a dense block of the measurement (most 16-cell blocks of a 40 x 30 grid
    touch more than 8 places: they are interpolated beforehand), a few references sharing a place
    and the corners of the grid outside the references' hull."""
    positions = rng.uniform(0, (4.0, 3.0), (n, 2))
    positions[n - 6 :] = positions[:6]  # six places with two references each
    headings = rng.uniform(-np.pi, np.pi, n)
    images = rng.integers(0, 256, (n, height, width), dtype=np.uint8)
    params = nightloc.PreparationParams(width=width, height=height)
    return nightloc.ReferenceMap(images, positions, headings, params=params)


def _settling_tables(rng, n, shifts=16, frames=8):
    """Random tables in which reference 0 matches best, at shift 3: a belief that settles."""
    tables = rng.uniform(15, 25, (frames, n, shifts)).astype(np.float32)
    tables[:, 0, 3] = 5.0
    return tables


@pytest.mark.sanitize
@pytest.mark.parametrize("noise", [0, 3])
def test_core_equals_the_numpy_oracle_on_a_map_of_many_places(noise):
    rng = np.random.default_rng(21)
    ref_map = _many_place_map(rng)
    loc = Localizer(ref_map, odometry_noise=noise, grid_width=40, grid_height=30)
    assert loc._filter.core.sparse_blocks > 0  # the interpolation of many places is exercised
    _drive_beside_oracle(loc, rng)


def test_heading_bins_other_than_columns_equal_the_oracle():
    rng = np.random.default_rng(22)
    ref_map = _random_map(rng, n=11)
    loc = Localizer(ref_map, odometry_noise=2, grid_width=30, grid_height=24, heading_bins=24)
    assert loc.pose_belief.shape[0] == 24
    _drive_beside_oracle(loc, rng)


def test_every_simd_path_gives_the_same_beliefs_on_a_map_of_many_places():
    rng = np.random.default_rng(23)
    ref_map = _many_place_map(rng, n=300)
    tables = _settling_tables(rng, len(ref_map))
    runs = {}
    for path in nightloc.available_simd_backends():
        with nightloc.use_simd_backend(path):
            loc = Localizer(ref_map, odometry_noise=3, grid_width=40, grid_height=30)
            runs[path] = [
                (loc.update_table(tables[k], motion if k else None), loc.pose_belief.copy())
                for k, motion in enumerate(MOTIONS)
            ]
    for path, out in runs.items():
        for (ea, ba), (eb, bb) in zip(runs["scalar"], out):
            assert (ea.x, ea.y, ea.heading, ea.credible_radius) == (eb.x, eb.y, eb.heading, eb.credible_radius), path
            assert np.array_equal(ba, bb), path


def _settled(noise_rule: float, rng_seed=24):
    """A localizer and its oracle after frames that settle on reference 0 (the robot standing)."""
    rng = np.random.default_rng(rng_seed)
    ref_map = _random_map(rng, n=12)
    loc = Localizer(ref_map, odometry_noise=1, grid_width=36, grid_height=28, negligible=noise_rule)
    oracle = _oracle(loc)
    tables = _settling_tables(rng, 12, frames=8)
    standing = RobotMotion(0.0, 0.0, 0.0)
    for k, table in enumerate(tables):
        loc.update_table(table, standing if k else None)
        if k:
            _apply(oracle, standing)
        oracle.update(table)
    return loc, oracle, rng


def test_negligible_bins_move_without_the_blur_as_the_oracle_does():
    loc, oracle, rng = _settled(1e-3)
    belief = loc.pose_belief
    top = belief.reshape(belief.shape[0], -1).max(axis=1)
    assert (top < 1e-3 * top.max()).sum() >= belief.shape[0] // 2  # most bins are negligible here
    exact, exact_oracle, _ = _settled(0.0)
    for motion in [RobotMotion(0.3, 0.1, 0.2), RobotMotion(0.2, 0.0, -0.1), RobotMotion(0.25, -0.05, 0.0)]:
        table = rng.uniform(15, 25, (12, 16)).astype(np.float32)
        table[0, 3] = 5.0
        estimate = loc.update_table(table, motion)
        _apply(oracle, motion)
        oracle.update(table)
        _check_against_oracle(loc, oracle, estimate)
        exact.update_table(table, motion)
        _apply(exact_oracle, motion)
        exact_oracle.update(table)
        # the rule changes the belief, by at most about its share of the peak per frame
        difference = np.abs(loc.pose_belief - exact.pose_belief).max()
        assert 0 < difference <= 3e-3 * exact.pose_belief.max()


@pytest.mark.slow
def test_a_map_of_20000_places_runs_within_its_memory_bound():
    n, bins, shifts = 20_000, 48, 48
    rng = np.random.default_rng(25)
    side = 0.4 * math.sqrt(n)  # a large lawn: references about 0.4 m apart
    images = rng.integers(0, 256, (n, 24, 48), dtype=np.uint8)
    ref_map = nightloc.ReferenceMap(images, rng.uniform(0, side, (n, 2)), rng.uniform(-np.pi, np.pi, n))
    loc = Localizer(ref_map, odometry_noise=3)
    for k in range(3):
        estimate = loc.update(images[k], RobotMotion(0.3, 0.0, 0.1) if k else None)
        assert math.isfinite(estimate.x) and math.isfinite(estimate.credible_radius)
    core = loc._filter.core
    cells = loc.grid.width * loc.grid.height
    places = loc.mapper.weights.shape[1]
    # the bound of nightloc/grid_filter.hpp (3 weights per cell of a triangulation) plus 1 MiB
    bound = 4 * (2 * bins * cells + 12 * cells + 2 * n * shifts + 8 * n + bins * (places + 1)) + 2**20
    assert core.memory_bytes <= bound
    assert core.memory_bytes < 24 * 2**20  # 17 MB measured: the map's images (22 MB) are more


def test_the_first_frames_are_tempered_and_reset_restarts_the_count():
    rng = np.random.default_rng(26)
    ref_map = _random_map(rng, n=10)
    tables = rng.uniform(15, 25, (16, 10, 16)).astype(np.float32)
    tempered = Localizer(ref_map, grid_width=24, grid_height=20, settle_frames=8)
    plain = Localizer(ref_map, grid_width=24, grid_height=20, settle_frames=0)
    for k, table in enumerate(tables):
        tempered.update_table(table)
        plain.update_table(table)
        assert tempered._filter.core.frames == k + 1
        assert tempered._filter.core.lambda_ == pytest.approx(min(1.0, (k + 1) / 8) * plain._filter.core.lambda_)
    tempered.reset()
    tempered.update_table(tables[0])
    assert tempered._filter.core.frames == 1
    mins = tables[0].min(axis=1).astype(np.float64)  # lambda = gain / (median - min), an eighth of it
    assert tempered._filter.core.lambda_ == pytest.approx(3.0 / (np.median(mins) - mins.min()) / 8)


def test_four_frames_agreeing_on_a_look_alike_do_not_make_the_start_confident():
    """The start of a run: a look-alike place that matches best in the first frames
    made the belief certain of it after four; tempered, the belief stays unsure (and says so)."""
    rng = np.random.default_rng(27)
    ref_map = _random_map(rng, n=14)
    tables = rng.uniform(15, 25, (4, 14, 16)).astype(np.float32)
    tables[:, 5, 7] = 8.0  # reference 5 matches clearly, every frame (the look-alike)
    standing = RobotMotion(0.0, 0.0, 0.0)
    confidence = {}
    for settle in (0, 12):
        loc = Localizer(ref_map, grid_width=30, grid_height=24, settle_frames=settle, score_cap=0.0)
        for k, table in enumerate(tables):
            estimate = loc.update_table(table, standing if k else None)
        confidence[settle] = estimate.confidence
    assert confidence[0] > 0.9 > 0.5 > confidence[12]


def test_update_from_a_frame_equals_update_from_its_table():
    rng = np.random.default_rng(3)
    ref_map = _random_map(rng, n=8, width=48, height=24)
    a, b = Localizer(ref_map), Localizer(ref_map)
    for k in range(4):
        query = nightloc.patch_normalize(rng.integers(0, 256, (24, 48), dtype=np.uint8))
        motion = RobotMotion(0.2, 0.0, 0.3) if k else None
        ea = a.update(query, motion)
        eb = b.update_table(nightloc.rotational_sad(query, ref_map.images), motion)
        assert (ea.x, ea.y, ea.heading, ea.credible_radius) == (eb.x, eb.y, eb.heading, eb.credible_radius)
        assert ea.best_ref == eb.best_ref and ea.score == eb.score


@pytest.mark.sanitize
@pytest.mark.parametrize("headings", [True, False])
def test_an_update_with_its_prior_is_the_prediction_then_the_update(headings):
    """The prior an update measured is the oracle's prediction, and the same, bit for bit, as a
    copy's predict() and belief; the belief after it the same as update_table's."""
    rng = np.random.default_rng(11)
    ref_map = _random_map(rng, n=10, headings=headings)
    a, b = Localizer(ref_map, odometry_noise=1), Localizer(ref_map, odometry_noise=1)
    oracle = _oracle(a)
    motions = [m for m in MOTIONS if headings or not isinstance(m, RobotMotion)]
    for k, motion in enumerate([None, *motions]):
        table = rng.uniform(15, 25, (len(ref_map), 16)).astype(np.float32)
        if k:
            ahead = copy.copy(b)
            ahead.predict(motion)
            expected_prior = ahead.belief
            _apply(oracle, motion)
        else:
            expected_prior = b.belief  # the first frame moves nothing
        estimate, prior = a.update_table_with_prior(table, motion)
        np.testing.assert_array_equal(prior, expected_prior)
        want = oracle.marginal()
        assert np.abs(prior - want).max() <= BELIEF_RTOL * want.max()
        expected = b.update_table(table, motion)
        oracle.update(table)
        assert estimate == expected
        np.testing.assert_array_equal(a.pose_belief, b.pose_belief)
    with pytest.raises(ValueError, match="table must be"):
        a.update_table_with_prior(np.zeros((3, 16), dtype=np.float32), None)


# ----------------------------------------------------------------------------------------------
# behaviour


def _lattice_world(rng, step=1.0, nx=7, ny=5, width=48, height=24):
    """References on a lattice, each a random prepared panorama; `view(p, heading)` renders a
    query at any pose as the nearest reference's image turned by the heading difference (plus
    noise): a world where the filter must find place and heading."""
    xs, ys = np.meshgrid(np.arange(nx) * step, np.arange(ny) * step)
    positions = np.column_stack([xs.ravel(), ys.ravel()])
    headings = rng.uniform(-np.pi, np.pi, len(positions))
    images = nightloc.patch_normalize(rng.integers(0, 256, (len(positions), height, width), dtype=np.uint8))
    ref_map = nightloc.ReferenceMap(images, positions, headings)

    def view(p, heading):
        k = int(np.argmin(np.hypot(*(positions - p).T)))
        turn = int(round((heading - headings[k]) * width / (2 * np.pi))) % width
        noisy = np.roll(images[k], turn, axis=1).astype(int) + rng.integers(-20, 21, (height, width))
        return np.clip(noisy, 0, 255).astype(np.uint8)

    return ref_map, view


def test_follows_a_robot_with_wheel_odometry_and_reports_heading():
    rng = np.random.default_rng(5)
    ref_map, view = _lattice_world(rng)
    loc = Localizer(ref_map, odometry_noise=1)
    pose = np.array([0.2, 0.3]), 0.3
    errors, heading_errors = [], []
    for k in range(14):  # then the circle leaves the lattice
        p, h = pose
        e = loc.update(view(p, h), RobotMotion(0.45, 0.0, 0.12) if k else None)
        errors.append(math.hypot(e.x - p[0], e.y - p[1]))
        heading_errors.append(abs(wrap_angle(e.heading - h)))
        pose = (p + 0.45 * np.array([math.cos(h), math.sin(h)]), h + 0.12)
    assert np.median(errors[4:]) < 0.5
    assert np.median(heading_errors[4:]) < math.radians(10)


def test_a_kidnapped_robot_is_found_again_within_ten_frames():
    rng = np.random.default_rng(6)
    ref_map, view = _lattice_world(rng)
    loc = Localizer(ref_map, odometry_noise=1)
    path = [(np.array([0.5 + 0.4 * k, 1.0]), 0.0) for k in range(12)]
    for k, (p, h) in enumerate(path):
        e = loc.update(view(p, h), RobotMotion(0.4, 0.0, 0.0) if k else None)
    assert math.hypot(e.x - path[-1][0][0], e.y - path[-1][0][1]) < 0.6
    # carried 4 m away and turned; the odometry says it did not move
    start = np.array([2.0, 4.0])
    recovered = None
    for k in range(12):
        p = start + np.array([0.4 * k, 0.0])
        e = loc.update(view(p, math.pi / 2), RobotMotion(0.0, 0.0, 0.0) if k == 0 else RobotMotion(0.0, -0.4, 0.0))
        if math.hypot(e.x - p[0], e.y - p[1]) < 1.0:
            recovered = k
            break
    assert recovered is not None and recovered <= 10


def test_uncertainty_shrinks_as_frames_agree_and_confidence_is_low_when_lost():
    rng = np.random.default_rng(8)
    ref_map, view = _lattice_world(rng)
    loc = Localizer(ref_map, odometry_noise=1)
    # one frame moves the belief by at most exp(likelihood_gain) against a median place: the
    # evidence of agreeing frames accumulates
    first = loc.update(view(np.array([3.0, 2.0]), 1.0))
    estimates = [loc.update(view(np.array([3.0, 2.0]), 1.0), RobotMotion(0.0, 0.0, 0.0)) for _ in range(19)]
    last = estimates[-1]
    assert last.credible_radius < 0.5 < first.credible_radius
    assert first.confidence < 0.5 < 0.95 < last.confidence
    assert all(a.confidence <= b.confidence + 1e-9 for a, b in itertools.pairwise(estimates))
    eig = np.linalg.eigvalsh(last.covariance)
    assert eig.min() >= -1e-12 and math.sqrt(eig.max()) < 1.0
    lost = loc.predict(None)  # unknown motion: the belief spreads
    assert lost.confidence < last.confidence and lost.credible_radius > last.credible_radius
    assert lost.best_ref == -1 and math.isnan(lost.score) and lost.frames == last.frames
    loc.reset()
    assert loc.belief == pytest.approx(np.full(loc.grid.shape, 1.0 / (loc.grid.width * loc.grid.height)))


def test_ties_carry_no_position():
    rng = np.random.default_rng(9)
    ref_map = _random_map(rng, n=6)
    loc = Localizer(ref_map, grid_width=20, grid_height=20)
    e = loc.update_table(np.full((6, 16), 20.0, dtype=np.float32))
    # a uniform belief times a flat likelihood: no peak, the estimate is the belief's mean
    grid = loc.grid
    assert (e.x, e.y) == pytest.approx((grid.x0 + grid.dx * 9.5, grid.y0 + grid.dy * 9.5))
    assert e.confidence < 0.5 and e.credible_radius > 0.5 * grid.dx * grid.width / 2


@pytest.mark.sanitize  # drives the core (CI runs it again under ASan + UBSan)
def test_nan_scores_raise_and_leave_the_belief_unchanged():
    rng = np.random.default_rng(10)
    ref_map = _random_map(rng, n=6)
    loc = Localizer(ref_map, grid_width=20, grid_height=20)
    loc.update_table(rng.uniform(15, 25, (6, 16)).astype(np.float32))
    before = loc.pose_belief.copy()
    bad = rng.uniform(15, 25, (6, 16)).astype(np.float32)
    bad[3, 5] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        loc.update_table(bad, RobotMotion(0.3, 0.0, 0.1))
    assert np.array_equal(loc.pose_belief, before)
    with pytest.raises(ValueError, match="finite"):
        RobotMotion(float("nan"))
    with pytest.raises(TypeError, match="float32"):
        loc.update_table(bad.astype(np.float64))
    with pytest.raises(ValueError, match=r"\(6, 16\)"):
        loc.update_table(np.zeros((5, 16), np.float32))


@pytest.mark.sanitize  # drives the core (CI runs it again under ASan + UBSan)
def test_a_robot_driven_off_the_map_keeps_a_defined_belief():
    rng = np.random.default_rng(12)
    ref_map = _random_map(rng, n=8)
    loc = Localizer(ref_map, grid_width=25, grid_height=25)
    loc.update_table(rng.uniform(15, 25, (8, 16)).astype(np.float32))
    e = loc.update_table(rng.uniform(15, 25, (8, 16)).astype(np.float32), MapDisplacement(500.0, 0.0))
    # every bit of the belief left the grid: what is left is the uniform floor, times this frame
    belief = loc.belief
    assert np.isfinite(belief).all() and belief.sum() == pytest.approx(1.0) and belief.min() > 0
    assert math.isfinite(e.x) and math.isfinite(e.credible_radius)
    grid = loc.grid
    assert grid.x0 - grid.dx <= e.x <= grid.x0 + grid.dx * grid.width


@pytest.mark.sanitize  # drives the core (CI runs it again under ASan + UBSan)
@pytest.mark.parametrize("n_refs", [1, 2])
@pytest.mark.parametrize("cap", [0.0, 1.45])
def test_one_or_two_references(n_refs, cap):
    rng = np.random.default_rng(13)
    ref_map = _random_map(rng, n=n_refs)
    loc = Localizer(ref_map, grid_width=21, grid_height=21, score_cap=cap)
    table = rng.uniform(15, 25, (n_refs, 16)).astype(np.float32)
    e = loc.update_table(table)
    assert math.isfinite(e.x) and math.isfinite(e.y) and 0 <= e.ref_index < n_refs
    if n_refs == 1:  # the median is the minimum: lambda 0, images say nothing about the place
        assert loc._filter.core.lambda_ == 0.0
    else:
        assert loc._filter.core.lambda_ > 0.0
        if not cap:  # capped, two random rows are mostly at the cap: the place of more good bins wins
            assert e.ref_index == int(np.argmin(table.min(axis=1)))
    e = loc.update_table(table, RobotMotion(0.2, 0.0, 0.5))
    assert math.isfinite(e.heading)


def test_map_without_headings_is_position_only_and_refuses_wheel_odometry():
    rng = np.random.default_rng(14)
    ref_map = _random_map(rng, n=6, headings=False)
    loc = Localizer(ref_map, grid_width=20, grid_height=20)
    e = loc.update_table(rng.uniform(15, 25, (6, 16)).astype(np.float32), RobotMotion(1.0))  # first: ignored
    assert math.isnan(e.heading) and loc.pose_belief.shape == (1, 20, 20)
    with pytest.raises(ValueError, match="map-frame"):
        loc.update_table(rng.uniform(15, 25, (6, 16)).astype(np.float32), RobotMotion(0.3))
    loc.update_table(rng.uniform(15, 25, (6, 16)).astype(np.float32), (0.3, 0.0))


def test_forward_camera_without_headings_is_position_only():
    rng = np.random.default_rng(15)
    ref_map = _random_map(rng, n=6, headings=False, shifts_all=False)
    loc = Localizer(ref_map, grid_width=20, grid_height=20)
    table = rng.uniform(15, 25, (6, 1)).astype(np.float32)
    e = loc.update_table(table)
    assert not loc._filter.can_pose and loc._filter.window == (0, 0)
    assert math.isnan(e.heading)
    with pytest.raises(ValueError, match="map-frame"):
        loc.update_table(table, RobotMotion(0.3))


@pytest.mark.sanitize
@pytest.mark.parametrize("seed", [0, 1])
def test_forward_camera_with_headings_equals_the_oracle(seed):
    """A forward camera's map keeps its headings: heading bins whose likelihood uses the references
    in view (column offsets within the window), driven by wheel odometry as a panorama's."""
    rng = np.random.default_rng(30 + seed)
    ref_map = _random_map(rng, n=14, shifts_all=False)
    loc = Localizer(ref_map, odometry_noise=2, grid_width=30, grid_height=24, field_of_view=60.0)
    f = loc._filter
    assert f.can_pose and f.core.forward and f.window == (4, 0) and list(f.columns) == list(range(-4, 5))
    _drive_beside_oracle(loc, rng, columns=9)
    # the frame's own table: the window search (means over the overlap)
    query = rng.integers(0, 256, (8, 16), dtype=np.uint8)
    want = shift_table(query, ref_map.images, [0], shift_window=(4, 0)).scores
    np.testing.assert_array_equal(loc.score_table(query, prepared=True), want)
    a, b = copy.copy(loc), copy.copy(loc)
    ea, eb = a.update(query, RobotMotion(0.1), prepared=True), b.update_table(want, RobotMotion(0.1))
    assert (ea.x, ea.y, ea.heading, ea.credible_radius) == (eb.x, eb.y, eb.heading, eb.credible_radius)


def _forward_world(rng, step=1.0, nx=7, ny=5, columns=48, height=24):
    """Places on a lattice, each seen by four references facing east, north, west and south: the
    forward quarter of a random panorama turned to each heading (each panorama cut to its forward
    90 degrees, left to right); `view(p, heading)` the forward view of the nearest place's panorama
    at any heading, with noise."""
    xs, ys = np.meshgrid(np.arange(nx) * step, np.arange(ny) * step)
    places = np.column_stack([xs.ravel(), ys.ravel()])
    panoramas = nightloc.patch_normalize(rng.integers(0, 256, (len(places), height, 4 * columns), dtype=np.uint8))

    def cut(panorama, heading):  # column 0 of a panorama looks along heading 0; columns turn right
        turn = round(heading * 4 * columns / (2 * np.pi))
        return np.roll(panorama, turn + columns // 2, axis=1)[:, :columns]

    headings = np.repeat([[0.0, np.pi / 2, np.pi, -np.pi / 2]], len(places), axis=0).ravel()
    positions = np.repeat(places, 4, axis=0)
    images = np.stack([cut(panoramas[i // 4], h) for i, h in enumerate(headings)])
    params = nightloc.PreparationParams(width=columns, height=height, wrap=False)
    ref_map = nightloc.ReferenceMap(images, positions, headings, params=params)

    def view(p, heading):
        k = int(np.argmin(np.hypot(*(places - p).T)))
        noisy = cut(panoramas[k], heading).astype(int) + rng.integers(-20, 21, (height, columns))
        return np.clip(noisy, 0, 255).astype(np.uint8)

    return ref_map, view


def test_forward_camera_follows_a_robot_with_wheel_odometry():
    rng = np.random.default_rng(31)
    ref_map, view = _forward_world(rng)
    loc = Localizer(ref_map, odometry_noise=1)
    assert loc._filter.can_pose
    pose = np.array([0.6, 0.8]), 0.3
    errors, heading_errors = [], []
    for k in range(16):
        p, h = pose
        e = loc.update(view(p, h), RobotMotion(0.35, 0.0, 0.12) if k else None, prepared=True)
        errors.append(math.hypot(e.x - p[0], e.y - p[1]))
        heading_errors.append(abs(wrap_angle(e.heading - h)))
        pose = (p + 0.35 * np.array([math.cos(h), math.sin(h)]), h + 0.12)
    assert np.median(errors[6:]) < 0.5
    assert np.median(heading_errors[6:]) < math.radians(10)


def test_map_frame_odometry_collapses_heading_and_wheel_odometry_restores_it():
    rng = np.random.default_rng(16)
    ref_map = _random_map(rng, n=8)
    loc = Localizer(ref_map, grid_width=20, grid_height=20)
    loc.update_table(rng.uniform(15, 25, (8, 16)).astype(np.float32))
    assert loc._filter.pose_mode
    loc.update_table(rng.uniform(15, 25, (8, 16)).astype(np.float32), (0.1, 0.2))
    assert not loc._filter.pose_mode and loc.pose_belief.shape[0] == 1
    loc.update_table(rng.uniform(15, 25, (8, 16)).astype(np.float32), RobotMotion(0.1))
    assert loc._filter.pose_mode and loc.pose_belief.shape[0] == 16


def test_heatmaps_and_belief():
    rng = np.random.default_rng(17)
    ref_map = _random_map(rng, n=8)
    loc = Localizer(ref_map, grid_width=24, grid_height=18)
    e = loc.update_table(rng.uniform(15, 25, (8, 16)).astype(np.float32), return_heatmap=True)
    assert e.heatmap.shape == (18, 24) and e.heatmap.sum() == pytest.approx(1.0)
    assert np.array_equal(e.heatmap, loc.belief)
    assert e.frame_heatmap.shape == (18, 24)
    assert loc.pose_belief.sum() == pytest.approx(1.0) and 0 <= loc.heading_offset < 2 * np.pi / 16


def test_api_errors_name_the_problem():
    rng = np.random.default_rng(18)
    ref_map = _random_map(rng, n=5)
    with pytest.raises(ValueError, match="method='paper'"):
        Localizer(ref_map, seq_len=5)
    with pytest.raises(ValueError, match="method"):
        Localizer(ref_map, method="kalman")
    with pytest.raises(TypeError, match="likelihood_gian"):
        Localizer(ref_map, likelihood_gian=2.0)
    with pytest.raises(ValueError, match="uniform_floor"):
        Localizer(ref_map, uniform_floor=1.5)
    with pytest.raises(ValueError, match="noise model"):
        Localizer(ref_map, odometry_noise=7)
    loc = Localizer(ref_map, grid_width=10, grid_height=10)
    result = nightloc.match(ref_map.images[0], ref_map.images)
    with pytest.raises(TypeError, match="rotational SAD table"):
        loc.update_match(result)
    with pytest.raises(ValueError, match="with_seq_len"):
        loc.with_seq_len(3)
    paper = Localizer(ref_map, method="paper", seq_len=3)
    with pytest.raises(AttributeError, match="filter"):
        _ = paper.belief


def test_filter_params_round_trip_through_toml(tmp_path):
    params = FilterParams(likelihood_gain=2.5, heading_bins=24)
    nightloc.save_params(tmp_path / "p.toml", params)
    assert nightloc.load_params(tmp_path / "p.toml", FilterParams) == params
    rng = np.random.default_rng(19)
    loc = Localizer(_random_map(rng, n=5), filter_params=params, grid_width=10, grid_height=10)
    assert loc._filter.core.heading_bins == 24


@pytest.mark.parametrize("cap", [0.0, 0.8, 1.45])
def test_one_frame_weighs_against_a_place_by_at_most_the_score_cap(cap):
    """The outlier-robust likelihood: a frame that matches a look-alike cannot
    erase a place: scores beyond s_min + score_cap (median - min) count as that one, so from a
    uniform start no cell holds less than exp(-likelihood_gain score_cap) of the most likely
    (without the cap, a place scoring far worse than the median is all but erased); the core
    equals the oracle."""
    rng = np.random.default_rng(31)
    ref_map = _random_map(rng, n=11, headings=False)
    loc = Localizer(ref_map, grid_width=60, grid_height=50, settle_frames=0, score_cap=cap)
    oracle = _oracle(loc)
    table = np.full((11, 16), 40.0, dtype=np.float32)
    table[:, 5] = [10.0] + [20.0] * 9 + [200.0]  # median 20, spread 10; the last place far worse
    estimate = loc.update_table(table)
    oracle.update(table)
    _check_against_oracle(loc, oracle, estimate)
    marginal = loc._filter.marginal()
    ratio = marginal.min() / marginal.max()
    if cap:
        assert ratio >= math.exp(-3.0 * cap) * (1 - 1e-4)
    else:  # the cells nearest the far worse place: under a twentieth of the default cap's share
        assert ratio < math.exp(-3.0 * 1.45) / 20


@pytest.mark.parametrize(("places", "lookalikes"), [(120, 64.0), (120, 0.0), (40, 64.0)])
def test_a_map_of_many_look_alikes_weighs_one_frame_less(places, lookalikes):
    """Look-alike tempering: on a map of P places with references, P above ``lookalike_places``,
    one frame weighs against a place by at most exp(-likelihood_gain score_cap ln(lookalike_places)
    / ln(P)) (the best of many places is more often a look-alike); smaller maps, and
    ``lookalike_places`` 0, keep ``score_cap``. The core equals the oracle."""
    rng = np.random.default_rng(47)
    ref_map = _random_map(rng, n=places, headings=False, area=(12.0, 8.0))
    loc = Localizer(ref_map, grid_width=48, grid_height=32, settle_frames=0, lookalike_places=lookalikes)
    oracle = _oracle(loc)
    cap = 1.45 * (math.log(lookalikes) / math.log(places) if lookalikes and places > lookalikes else 1.0)
    assert loc._filter.core.score_cap == pytest.approx(cap) and oracle.score_cap == pytest.approx(cap)
    table = np.full((places, 16), 60.0, dtype=np.float32)
    table[:, 3] = rng.uniform(20.0, 40.0, places)
    table[0, 3], table[1, 3] = 5.0, 400.0  # one place far better, one far worse than the rest
    estimate = loc.update_table(table)
    oracle.update(table)
    _check_against_oracle(loc, oracle, estimate)
    marginal = loc._filter.marginal()
    assert marginal.min() / marginal.max() >= math.exp(-3.0 * cap) * (1 - 1e-4)
    if cap < 1.45:  # tighter than the untempered bound, which the worst cells reach
        assert marginal.min() / marginal.max() > 1.5 * math.exp(-3.0 * 1.45)


def test_a_single_distant_look_alike_does_not_move_the_estimate_but_consistent_frames_do():
    """On a lawn-sized map of look-alike places, a robot tracked by its odometry: one frame whose
    best match is a place 8 m away (its own place scoring as a median place) leaves the estimate
    on the track; frames that keep matching that place (the robot was carried there) move it."""
    rng = np.random.default_rng(5)
    xs, ys = np.meshgrid(np.arange(0.5, 12.0, 0.5), np.arange(0.5, 6.0, 0.5))
    positions = np.column_stack([xs.ravel(), ys.ravel()])
    n = len(positions)  # 253 places
    images = rng.integers(0, 256, (n, 8, 16), dtype=np.uint8)
    params = nightloc.PreparationParams(width=16, height=8, wrap=False)
    ref_map = nightloc.ReferenceMap(images, positions, None, params=params)
    loc = Localizer(ref_map, odometry_noise=1, grid_width=48, grid_height=24)
    here = np.argmin(np.hypot(*(positions - (2.0, 3.0)).T))
    far = np.argmin(np.hypot(*(positions - (10.0, 3.0)).T))

    def frame(best):
        scores = rng.uniform(30.0, 40.0, n).astype(np.float32)
        scores[best] = 10.0
        return scores[:, None]

    estimate = None
    for _ in range(25):  # standing at (2, 3): the frames agree
        estimate = loc.update_table(frame(here), MapDisplacement(0.0, 0.0))
    assert math.hypot(estimate.x - 2.0, estimate.y - 3.0) < 0.5
    estimate = loc.update_table(frame(far), MapDisplacement(0.0, 0.0))
    assert math.hypot(estimate.x - 2.0, estimate.y - 3.0) < 0.5  # one frame: still on the track
    moved = None
    for k in range(1, 16):
        estimate = loc.update_table(frame(far), MapDisplacement(0.0, 0.0))
        if math.hypot(estimate.x - 10.0, estimate.y - 3.0) < 0.5:
            moved = k
            break
    assert moved is not None and moved >= 2  # carried off: found within 15 frames, not at once
