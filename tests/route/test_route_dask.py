"""The Dask backend (optional extra): blocked on a LocalCluster, identical to the in-process path."""

from __future__ import annotations

import numpy as np
import pytest

from nightloc import route

import route_oracle as ro

pytest.importorskip("dask", reason="the optional dask extra is not installed (pip install 'nightloc[dask]')")
distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")

from nightloc.route.dask_backend import (  # noqa: E402
    dask_match_prepared,
    dask_route_matrices,
    dask_stream_match,
    local_client,
)
from nightloc.route.preview import matrix_preview  # noqa: E402


@pytest.fixture(scope="module")
def client():
    # local_client's cluster binds its HTTP server to a free port: a fixed port (the dashboard's
    # 8787) may be taken on the machine that runs the tests.
    with local_client(1, threads_per_worker=2, processes=False) as dask_client:
        yield dask_client


@pytest.mark.parametrize(
    ("preset", "mode", "method"),
    [("openseqslam", "centred", "seqslam"), ("nightloc", "causal", "seqslam"), ("nightloc", "centred", "filter")],
)
def test_dask_equals_in_process(client, preset, mode, method):
    refs, queries, _ = ro.synthetic_route(140, 130, speed=1.05, seed=21)
    params = route.resolve_params(preset, mode=mode, method=method)
    expected = route.match_prepared(refs, queries, params)
    # Blocks smaller than the trajectories' reach, and uneven: the halo logic is exercised.
    result = dask_match_prepared(refs, queries, params, rows_per_block=17, keep_difference=True, client=client)
    np.testing.assert_array_equal(result.refs, expected.refs)
    np.testing.assert_array_equal(result.scores, expected.scores)
    np.testing.assert_array_equal(result.enhanced.compute(), expected.enhanced)
    np.testing.assert_array_equal(result.difference.compute(), expected.difference)
    if method == "filter":  # the filter continued over the blocks brought to the client in order
        np.testing.assert_array_equal(result.confidence, expected.confidence)
        np.testing.assert_array_equal(result.off_route, expected.off_route)


def test_dask_matrices_without_difference(client):
    refs, queries, _ = ro.synthetic_route(60, 50, speed=1.0, seed=22)
    difference, enhanced, blocks = dask_route_matrices(refs, queries, "openseqslam", rows_per_block=16)
    assert difference is None and blocks == [(0, 16), (16, 32), (32, 48), (48, 50)]
    expected = route.match_prepared(refs, queries, "openseqslam")
    np.testing.assert_array_equal(client.compute(enhanced, sync=True), expected.enhanced)
    with pytest.raises(ValueError, match="rows_per_block"):
        dask_route_matrices(refs, queries, rows_per_block=0)
    with pytest.raises(ValueError, match="too few"):
        dask_match_prepared(refs[:5], queries, route.RouteParams(method="seqslam"))


# --------------------------------------------------------------------------------------------
# streaming bands of query rows (nightloc route --dask)


@pytest.fixture(scope="module")
def loopback():
    """A LocalCluster on loopback TCP, its two workers threads of this process."""
    with local_client(2, 1, processes=False) as dask_client:
        yield dask_client


def _slow_route(seed: int = 2):
    positions = np.arange(0.0, 139.0, 0.45)  # outside the default models' speeds: the check speaks
    return ro.synthetic_route_at(140, positions, seed=seed, likeness=0.5)


@pytest.mark.parametrize(
    ("preset", "changes"),
    [
        ("nightloc", {}),
        ("nightloc", {"filter_motion": "window"}),
        ("openseqslam", {}),
        ("nightloc", {"method": "seqslam", "mode": "causal"}),
        ("nightloc", {"method": "seqslam", "mode": "centred"}),
    ],
)
def test_streamed_bands_equal_the_single_machine_run(loopback, preset, changes):
    refs, queries, _ = _slow_route()
    params = route.resolve_params(preset, **changes)
    expected = route.match_prepared(refs, queries, params)
    # uneven bands shorter than SeqSLAM's reach, few in flight: every band's halo and order matter
    result = dask_stream_match(loopback, refs, queries, params, rows_per_band=17, in_flight=3)
    np.testing.assert_array_equal(result.refs, expected.refs)
    np.testing.assert_array_equal(result.scores, expected.scores)
    if params.method == "filter":
        for name in ("confidence", "off_route", "speed", "weights"):
            np.testing.assert_array_equal(getattr(result, name), getattr(expected, name))
        assert result.motion == expected.motion == params.filter_motion
    assert result.speed_check == expected.speed_check and not result.speed_check.fits
    assert result.difference is None and result.enhanced.shape == expected.enhanced.shape
    np.testing.assert_allclose(result.matrix_image, matrix_preview(expected.enhanced), rtol=1e-6, atol=1e-6)


def test_streamed_odometry_model_equals_the_single_machine_run(loopback):
    refs, queries, _ = _slow_route(seed=4)
    positions = np.arange(0.0, 139.0, 0.45)
    advances, distances = np.r_[0.0, np.diff(positions)] * 0.3, np.arange(140.0) * 0.3
    expected = route.match_prepared(refs, queries, advances=advances, reference_distances=distances)
    result = dask_stream_match(
        loopback, refs, queries, advances=advances, reference_distances=distances, rows_per_band=23
    )
    assert result.motion == expected.motion == "odometry"
    for name in ("refs", "confidence", "off_route", "speed"):
        np.testing.assert_array_equal(getattr(result, name), getattr(expected, name))
    assert result.speed_check == expected.speed_check and result.speed_check.ratio.source == "odometry"


def test_memory_is_bounded_by_the_bands_in_flight(loopback):
    """Every band a worker computed is released once the client has used it: at the end no band
    stays on the cluster (only the scattered references), and at most ``in_flight`` were held."""
    refs, queries, _ = ro.synthetic_route(150, 400, speed=0.35, seed=7)
    seen = []
    original = loopback.submit

    def counting_submit(*args, **kwargs):
        seen.append(len(loopback.who_has()))
        return original(*args, **kwargs)

    loopback.submit = counting_submit
    try:
        dask_stream_match(loopback, refs, queries, rows_per_band=10, in_flight=4)
    finally:
        del loopback.submit
    assert len(seen) == 40
    assert max(seen) <= 1 + 4  # the references and at most in_flight bands
    assert len(loopback.who_has()) <= 1


def test_stream_refuses_bad_bands(loopback):
    refs, queries, _ = ro.synthetic_route(30, 20, speed=1.0, seed=8)
    with pytest.raises(ValueError, match="rows_per_band"):
        dask_stream_match(loopback, refs, queries, rows_per_band=0)
    with pytest.raises(ValueError, match="in_flight"):
        dask_stream_match(loopback, refs, queries, in_flight=0)
    with pytest.raises(ValueError, match="both advances and reference_distances"):
        dask_stream_match(loopback, refs, queries, advances=np.zeros(20))
