"""Route mode (1D SeqSLAM) throughput: difference matrix + contrast enhancement + trajectory search.

The Nordland subset (summer reference, winter query, 64x32, OpenSeqSLAM preset, shift 0), from
``../shared/data/nordland`` when present (else synthetic frames of the same size), prepared once
outside the timing (image decoding excluded, as in the target). Groups by size N x N:

* ``numpy`` (N = 500): the numpy oracle of ``tests/route_oracle.py`` (chunked integer SAD,
  float32 enhancement, per-query vectorized search), bit-identical to the core;
* ``core`` (1 and 2 threads): :func:`nightloc.route.match_prepared`.

Target: N = 3576 in <= 3 s on 2 cores. OpenSeqSLAM under Octave's time for N = 500, by stage, is
in ../shared/data/golden/README.md and docs/route_mode.md ("Speed").

    python -m pytest benchmarks/test_bench_route.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from nightloc import route
from nightloc.route.params import DISTANCE_MOTIONS

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import oracle
import route_oracle as ro
from conftest import shared_data_dir
from route_support import NORDLAND_GROUP, default_match

SIZES = [500, 3576]
_cache: dict = {}


def nordland(n):
    """(refs, queries, real) prepared with the OpenSeqSLAM preset: sorted positions 1000.. for
    N = 500 (the golden subset A), the whole route for N = 3576."""
    if n in _cache:
        return _cache[n]
    root = shared_data_dir() / "nordland"
    preparer = route.RoutePreparer(route.route_preset("openseqslam"))
    if (root / "summer").is_dir():
        names = sorted(p.name for p in (root / "summer").iterdir() if p.suffix == ".png")
        chosen = names[1000:1500] if n == 500 else names[:n]

        def load(season):
            return preparer([cv2.imread(str(root / season / name), cv2.IMREAD_COLOR) for name in chosen])

        refs, queries, real = load("summer"), load("winter"), len(chosen) == n
    else:
        refs, queries, _ = ro.synthetic_route(n, n, speed=1.0, seed=n, height=32, width=64)
        refs, queries, real = preparer(refs), preparer(queries), False
    _cache.clear()
    _cache[n] = (refs, queries, real)
    return _cache[n]


def numpy_difference(queries, refs, chunk=8):
    """OpenSeqSLAM's D (n_query, n_ref): exact integer SAD in numpy, divided by n_ref."""
    r = refs.reshape(len(refs), -1).astype(np.int16)
    sums = np.empty((len(queries), len(refs)), dtype=np.int64)
    for start in range(0, len(queries), chunk):
        q = queries[start : start + chunk].reshape(-1, r.shape[1]).astype(np.int16)
        sums[start : start + chunk] = np.abs(q[:, None, :] - r[None]).sum(axis=2, dtype=np.int64)
    return oracle.scores_from_sums(sums, len(refs))


def numpy_pipeline(refs, queries):
    d = numpy_difference(queries, refs)
    dd = ro.enhance_openseqslam(d)
    return ro.find_matches_centred(dd)


def record(benchmark, result, n):
    benchmark.extra_info["cells"] = n * n
    if result is not None:
        benchmark.extra_info.update({f"{k}_s": round(v, 4) for k, v in result.timings.items()})


def test_numpy_oracle(benchmark):
    n = 500
    refs, queries, _ = nordland(n)
    benchmark.group = f"route pipeline, {n} x {n}"
    matched, scores = benchmark.pedantic(numpy_pipeline, args=(refs, queries), rounds=1)
    record(benchmark, None, n)
    core = route.match_prepared(refs, queries, "openseqslam")
    np.testing.assert_array_equal(matched, core.refs)
    np.testing.assert_array_equal(scores, core.scores)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("n", SIZES)
def test_core(benchmark, n, threads):
    refs, queries, real = nordland(n)
    benchmark.group = f"route pipeline, {n} x {n}"
    result = benchmark.pedantic(
        route.match_prepared,
        args=(refs, queries, "openseqslam"),
        kwargs={"threads": threads, "keep_difference": False},
        rounds=3 if n <= 500 else 2,
        warmup_rounds=0,
    )
    record(benchmark, result, n)
    truth = route.GroundTruth.from_frames(n, n, 2)
    evaluation = route.evaluate_matches(result.refs, result.scores, truth)
    benchmark.extra_info["recall_at_100"] = round(evaluation.recall_at_100, 4)
    if real:
        # Golden subset A: 0.402 (OpenSeqSLAM's own figure); the full route: 0.355 (README).
        assert round(evaluation.recall_at_100, 3) == (0.402 if n == 500 else 0.355)
    else:
        assert evaluation.recall_at_100 > 0.5


# --------------------------------------------------------------------------------------------
# The search alone over one enhanced 3576 x 3576 matrix: SeqSLAM's trajectory search against the
# route filter (the target: the filter's whole search costs less than SeqSLAM's). Nordland with
# the default ("nightloc") preparation when present, else synthetic frames of the same size.

_search_cache: dict = {}


def nightloc_enhanced(n=3576):
    """(enhanced matrix with the causal offset, texture weights, real) for the default preparation:
    the whole Nordland route (the tests' match of it, computed once per process), else n x n
    synthetic frames."""
    if n in _search_cache:
        return _search_cache[n]
    root = shared_data_dir() / "nordland"
    params = route.RouteParams()
    if (root / "summer").is_dir():
        matched = default_match(shared_data_dir(), "nordland/summer", "nordland/winter").result
        enhanced, weights, real = matched.enhanced, matched.weights, matched.n_refs == n
    else:
        preparer = route.RoutePreparer(params)
        refs, queries, _ = ro.synthetic_route(n, n, speed=1.0, seed=n, height=32, width=64)
        refs, queries, real = preparer(refs), preparer(queries), False
        difference = route.route_difference_matrix(queries, refs, params)
        enhanced = route.enhance_contrast(difference, params, offset="bound")
        weights = route.texture_weights(queries, params.filter_min_texture)
    _search_cache.clear()
    _search_cache[n] = (enhanced, weights, real)
    return _search_cache[n]


@pytest.mark.xdist_group(NORDLAND_GROUP)
@pytest.mark.parametrize("threads", [1, 2])
def test_search_seqslam(benchmark, threads):
    enhanced, _, _ = nightloc_enhanced()
    benchmark.group = "route search only, 3576 x 3576 (enhanced matrix given)"
    params = route.RouteParams(method="seqslam")
    refs, scores = benchmark.pedantic(route.trajectory_search, args=(enhanced, params, threads), rounds=2)
    truth = route.GroundTruth.from_frames(len(refs), enhanced.shape[1], 2)
    benchmark.extra_info["recall_at_100"] = round(route.evaluate_matches(refs, scores, truth).recall_at_100, 4)


MOTIONS = {
    "window": (route.RouteParams(filter_motion="window"), False),
    "speed": (route.RouteParams(filter_motion="speed"), False),
    "odometry": (route.RouteParams(), True),
}


@pytest.mark.xdist_group(NORDLAND_GROUP)
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("motion", sorted(MOTIONS))
def test_search_filter(benchmark, threads, motion):
    """The filter's three motion models over the aligned Nordland pair (odometry: one
    reference per frame on both sides)."""
    enhanced, weights, real = nightloc_enhanced()
    benchmark.group = "route search only, 3576 x 3576 (enhanced matrix given)"
    params, odometry = MOTIONS[motion]
    steps = np.ones(len(enhanced)) if odometry else None
    distances = np.arange(float(enhanced.shape[1])) if odometry else None
    refs, confidence, _ = benchmark.pedantic(
        route.route_filter,
        args=(enhanced, params, weights, threads),
        kwargs={"advances": steps, "reference_distances": distances},
        rounds=3 if motion == "window" else 1,
    )
    truth = route.GroundTruth.from_frames(len(refs), enhanced.shape[1], 2)
    evaluation = route.evaluate_matches(refs, 1.0 - confidence, truth)
    benchmark.extra_info["recall_at_100"] = round(evaluation.recall_at_100, 4)
    if real:
        assert evaluation.best_f1 >= 0.92 and evaluation.recall_at_100 >= 0.65  # route mode's targets


def _small_route(n=150):
    rng = np.random.default_rng(n)
    matrix = rng.normal(size=(n, n)).astype(np.float32)
    matrix[np.arange(n), np.arange(n)] -= 2.0
    return matrix, np.ones(n), np.arange(float(n))


#: The models that keep a belief over cells (the window model's is the references' own).
CELL_MODELS = [name for name in route.MOTION_MODELS if name != "window"]


@pytest.mark.parametrize("motion", CELL_MODELS)
def test_filter_motion_oracle(benchmark, motion):
    """The numpy oracle of the models over cells (tests/route_oracle.py), 150 x 150."""
    matrix, steps, distances = _small_route()
    benchmark.group = f"route filter {motion} model, 150 x 150"
    params = route.RouteParams(filter_motion="speed")
    extra = (steps, distances) if motion in DISTANCE_MOTIONS else (None, None)
    benchmark.pedantic(ro.route_filter_planes, args=(matrix, params, None, *extra), rounds=1)


@pytest.mark.parametrize("motion", CELL_MODELS)
def test_filter_motion_core(benchmark, motion):
    """The core's models over cells, 150 x 150, one thread."""
    matrix, steps, distances = _small_route()
    benchmark.group = f"route filter {motion} model, 150 x 150"
    params = route.RouteParams(filter_motion="speed")
    kwargs = {"advances": steps, "reference_distances": distances} if motion in DISTANCE_MOTIONS else {}
    benchmark.pedantic(route.route_filter, args=(matrix, params, None, 1), kwargs=kwargs, rounds=5)
