"""The Dask backend (optional extra): blocked on a LocalCluster, identical to the in-process path."""

from __future__ import annotations

import numpy as np
import pytest

from nightloc import route

import route_oracle as ro

pytest.importorskip("dask", reason="the optional dask extra is not installed (pip install 'nightloc[dask]')")
distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")

from nightloc.route.dask_backend import dask_match_prepared, dask_route_matrices  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None)
    with distributed.Client(cluster) as dask_client:
        yield dask_client
    cluster.close()


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
