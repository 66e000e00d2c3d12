"""The route filter (nightloc.route.filter): the core against the numpy oracle written from the
model's definition (tests/route_oracle.py), the streaming localizer against the batch, and the
behaviours the filter promises: re-acquisition after a kidnap, flat frames only predicted, an
off-route state that rises when the frames match nothing."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import nightloc
from nightloc import route

import route_oracle as ro

pytestmark = pytest.mark.sanitize  # drives the compiled filter: CI reruns it under ASan + UBSan

WINDOW = route.RouteParams(filter_motion="window")  # the oracle below is the window model's
PARAMS = [
    WINDOW,
    dataclasses.replace(WINDOW, filter_clip=math.inf, filter_floor=0.02, filter_leave=0.0, filter_window=1),
    dataclasses.replace(WINDOW, vmin=0.0, vmax=2.5, filter_backward=0.05, filter_sharpness=1.5, filter_clip=0.5),
    dataclasses.replace(WINDOW, vmin=1.0, vmax=1.0, filter_floor=0.0, filter_leave=0.05, filter_rejoin=0.3),
]


@pytest.mark.parametrize(
    ("vmin", "vmax", "backward"), [(0.8, 1.2, 0.0), (0.5, 1.5, 0.0), (1.0, 1.0, 0.0), (0.0, 2.5, 0.1), (2.0, 3.0, 0.3)]
)
def test_motion_kernel_equals_oracle(vmin, vmax, backward):
    first, weights = route.motion_kernel(vmin, vmax, backward)
    got = {first + i: w for i, w in enumerate(weights) if w > 0}
    expected = ro.motion_kernel(vmin, vmax, backward)
    assert sorted(got) == sorted(expected)
    for k, w in expected.items():
        assert got[k] == pytest.approx(w, rel=1e-13, abs=1e-15)
    assert weights.sum() == pytest.approx(1.0, abs=1e-14)
    # The mean advance is the mean speed (less the backward steps).
    mean = sum(k * w for k, w in got.items())
    assert mean == pytest.approx((1 - backward) * (vmin + vmax) / 2 - backward, abs=1e-12)


@pytest.mark.parametrize("index", range(len(PARAMS)))
def test_filter_equals_oracle(index):
    p = PARAMS[index]
    n_query, n_ref = 120, 90
    matrix, weights = ro.noisy_matrix(index, n_query, n_ref)
    refs, confidence, off_route = route.route_filter(matrix, p, weights)
    o_refs, o_confidence, o_off, o_belief = ro.route_filter(matrix, p, weights)
    np.testing.assert_array_equal(refs, o_refs)
    np.testing.assert_allclose(confidence, o_confidence, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(off_route, o_off, rtol=1e-9, atol=1e-13)
    # Frame by frame, the same (bit-identical to the batch), and the same final belief.
    f = route.RouteFilter(n_ref, p)
    steps = [f.step(matrix[q], weights[q]) for q in range(n_query)]
    np.testing.assert_array_equal([s.ref for s in steps], refs)
    np.testing.assert_array_equal([s.confidence for s in steps], confidence)
    np.testing.assert_array_equal([s.off_route for s in steps], off_route)
    np.testing.assert_allclose(f.belief, o_belief, rtol=1e-9, atol=1e-15)
    assert f.belief.sum() + f.off_route == pytest.approx(1.0, abs=1e-12)


def test_identical_on_every_simd_path(simd_path):
    """The likelihood loop has baseline, AVX2 and AVX-512 builds: the same bits on each."""
    rng = np.random.default_rng(12)
    matrix = rng.normal(size=(60, 333)).astype(np.float32)
    matrix[3, 5] = np.nan
    params = route.RouteParams(filter_clip=0.5, filter_sharpness=3.0)
    with nightloc.use_simd_backend("scalar"):
        expected = route.route_filter(matrix, params)
    for got, want in zip(route.route_filter(matrix, params), expected):
        np.testing.assert_array_equal(got, want)


def test_threads_and_blocks_do_not_change_the_result():
    rng = np.random.default_rng(3)
    matrix = rng.normal(size=(150, 70)).astype(np.float32)
    one = route.route_filter(matrix, threads=1)
    for threads in (2, 3):
        for got, expected in zip(route.route_filter(matrix, threads=threads), one):
            np.testing.assert_array_equal(got, expected)
    # Continuing over blocks of rows (as the Dask backend does) equals one run.
    f = route.RouteFilter(70)
    pieces = [f.run(matrix[a:b]) for a, b in ((0, 33), (33, 34), (34, 150))]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in pieces]), one[0])
    np.testing.assert_array_equal(np.concatenate([p[1] for p in pieces]), one[1])


def test_texture_weights_equal_oracle():
    rng = np.random.default_rng(4)
    images = rng.integers(120, 137, size=(6, 8, 12), dtype=np.uint8)
    images[0] = 128
    images[1, :, :6] = 127  # mean absolute deviation 0.5
    images[1, :, 6:] = 128
    for min_texture in (0.0, 1.0, 3.0):
        np.testing.assert_allclose(route.texture_weights(images, min_texture), ro.texture_weights(images, min_texture))
    w = route.texture_weights(images, 1.0)
    assert w[0] == 0.0 and w[1] == pytest.approx(0.5)


def _routes(seed=5, n_ref=300):
    refs, _, _ = ro.synthetic_route(n_ref, 10, speed=1.0, seed=seed)
    # Queries showing reference t: darker, with noise (as synthetic_route's queries).
    rng = np.random.default_rng(seed + 1)

    def show(indices):
        world = refs[indices].astype(np.float64)
        return np.clip(0.6 * world + 20 + rng.normal(0, 12.0, world.shape), 0, 255).astype(np.uint8)

    return refs, show


def test_follows_the_route_and_reacquires_after_a_kidnap():
    """Queries follow references 20..99, then the robot is carried to 200..279 (a kidnap): the
    filter is back on the route within 15 frames and stays there."""
    refs, show = _routes()
    truth = np.concatenate([np.arange(20, 100), np.arange(200, 280)])
    queries = show(truth)
    result = route.match_prepared(refs, queries, route.RouteParams(enhance_radius=5))
    correct = np.abs(result.refs - truth) <= 2
    assert correct[10:80].all()
    back = next(i for i in range(80, 160) if correct[i:].all())
    assert back - 80 <= 15, f"re-acquired after {back - 80} frames"
    # Confidence drops right after the kidnap and recovers.
    assert result.confidence[80:83].max() < result.confidence[70:80].min()
    assert np.median(result.confidence[back + 5 :]) > 0.9


def test_flat_frames_leave_the_belief_as_predicted():
    refs, show = _routes(seed=6)
    localizer = nightloc.RouteLocalizer(refs, WINDOW, prepared=True)
    for t in range(30, 60):
        localizer.update(show(np.array([t]))[0], prepared=True)
    before = localizer.belief
    before_off = 1.0 - before.sum()
    flat = np.full(refs.shape[1:], 128, np.uint8)
    update = localizer.update(flat, prepared=True)
    predicted, predicted_off = ro.filter_predict(before, before_off, localizer.params)
    np.testing.assert_allclose(localizer.belief, predicted, rtol=1e-12, atol=1e-16)
    assert update.off_route == pytest.approx(predicted_off, rel=1e-12)
    # Several flat frames in a row: the belief moves on at the route's speed and is found again.
    for _ in range(5):
        localizer.update(flat, prepared=True)
    assert abs(int(np.argmax(localizer.belief)) - 65) <= 2
    update = localizer.update(show(np.array([66]))[0], prepared=True)
    assert abs(update.ref - 66) <= 2


def test_off_route_frames_raise_the_off_route_probability():
    refs, show = _routes(seed=7)
    rng = np.random.default_rng(8)
    strangers = rng.integers(0, 256, size=(60, *refs.shape[1:]), dtype=np.uint8)  # another place
    queries = np.concatenate([show(np.arange(10, 70)), strangers, show(np.arange(190, 250))])
    result = route.match_prepared(refs, queries)
    on_route = slice(40, 60)
    assert result.off_route[on_route].max() < 0.02 and result.confidence[on_route].min() > 0.9
    # Twenty frames after leaving, no stranger is as confident as any on-route frame, and the
    # off-route state holds a large share of the belief (the on-route rest is spread out).
    strangers_late = slice(80, 120)
    assert result.confidence[strangers_late].max() < result.confidence[on_route].min()
    assert np.median(result.confidence[strangers_late]) < 0.5
    assert np.median(result.off_route[strangers_late]) > 0.3
    # Back on the route: found again within a few frames, off-route probability low.
    assert (np.abs(result.refs[126:] - np.arange(196, 250)) <= 2).all()
    assert np.median(result.off_route[140:]) < 0.02


def test_streaming_equals_batch_bit_for_bit():
    refs, queries, _ = ro.synthetic_route(150, 90, speed=1.1, seed=9)
    queries[40] = 128  # a flat frame (weight 0)
    params = route.RouteParams(filter_min_texture=3.0)
    batch = route.match_prepared(refs, queries, params, threads=2)
    localizer = nightloc.RouteLocalizer(refs, params, prepared=True, threads=1)
    updates = [localizer.update(q, prepared=True) for q in queries]
    np.testing.assert_array_equal([u.ref for u in updates], batch.refs)
    np.testing.assert_array_equal([u.confidence for u in updates], batch.confidence)
    np.testing.assert_array_equal([u.off_route for u in updates], batch.off_route)
    np.testing.assert_array_equal([u.score for u in updates], batch.scores)
    np.testing.assert_array_equal(localizer.last_row, batch.enhanced[-1])
    assert batch.weights[40] == 0.0
    localizer.reset()
    assert localizer.frames_seen == 0
    np.testing.assert_allclose(localizer.belief, 1.0 / len(refs), rtol=1e-12)


def test_method_selection_and_summary_fields():
    refs, queries, _ = ro.synthetic_route(80, 60, speed=1.0, seed=10)
    default = route.match_prepared(refs, queries)
    assert default.method == "filter" and default.confidence is not None and (default.refs >= 0).all()
    seqslam = route.match_prepared(refs, queries, route.resolve_params(None, method="seqslam"))
    assert seqslam.method == "seqslam" and seqslam.confidence is None and (seqslam.refs < 0).any()
    assert route.route_preset("openseqslam").method == "seqslam"
    assert set(route.RouteParams().method_params()) >= {"filter_sharpness", "vmin", "enhance_radius"}
    assert "ds" in route.RouteParams(method="seqslam").method_params()
    localizer = nightloc.RouteLocalizer(refs, method="seqslam", prepared=True)
    assert localizer.params.method == "seqslam" and localizer.belief is None
    # The route's default preparation: no equalization (see docs/route_mode.md).
    assert route.default_preparation(route.RouteParams()).equalize == "none"


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"filter_sharpness": -1.0}, "filter_sharpness"),
        ({"filter_sharpness": math.nan}, "filter_sharpness"),
        ({"filter_clip": math.nan}, "filter_clip"),
        ({"filter_clip": -math.inf}, "filter_clip"),
        ({"filter_floor": 1.5}, "filter_floor"),
        ({"filter_leave": -0.1}, "filter_leave"),
        ({"filter_rejoin": 2.0}, "filter_rejoin"),
        ({"filter_backward": 1.0}, "filter_backward"),
        ({"filter_window": -1}, "filter_window"),
        ({"filter_min_texture": -2.0}, "filter_min_texture"),
        ({"vmin": -0.5}, "vmin"),
        ({"method": "seqslam", "vmin": 0.0}, "vmin"),
    ],
)
def test_bad_parameters_are_named(change, words):
    with pytest.raises(ValueError, match=words):
        dataclasses.replace(route.RouteParams(), **change)


def test_bad_inputs_raise_clear_errors():
    f = route.RouteFilter(10)
    with pytest.raises(ValueError, match=r"shape \(10,\)"):
        f.step(np.zeros(9, np.float32))
    with pytest.raises(TypeError, match="float32"):
        f.step(np.zeros(10))
    with pytest.raises(ValueError, match="weight"):
        f.step(np.zeros(10, np.float32), 1.5)
    with pytest.raises(ValueError, match="n_refs"):
        route.RouteFilter(0)
    with pytest.raises(ValueError, match="weights"):
        route.route_filter(np.zeros((4, 10), np.float32), weights=np.array([0.5, 2.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="weights"):
        route.route_filter(np.zeros((4, 10), np.float32), weights=np.ones(3))
    with pytest.raises(TypeError, match="float32"):
        route.route_filter(np.zeros((4, 10)))
    with pytest.raises(ValueError, match="not all be 0"):
        f.set_state(np.zeros(10), 0.0)
    with pytest.raises(ValueError, match="min_texture"):
        route.texture_weights(np.zeros((2, 4, 4), np.uint8), -1.0)
    f.set_state(np.arange(10.0), 0.5)
    assert f.belief.sum() + f.off_route == pytest.approx(1.0)
