"""Threads: independent localizers in 8 threads give exactly their serial results, and a shared
ReferenceMap is read-only and safe to share.

(The compiled core's own thread tests, GIL release included, are in test_concurrency_core.py.)
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import nightloc
from nightloc import route

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize

THREADS = 8


def _route_problem(seed: int, n_refs: int = 120, n_frames: int = 60):
    rng = np.random.default_rng(seed)
    refs = nightloc.patch_normalize(rng.integers(0, 256, (n_refs, 24, 48), dtype=np.uint8), wrap=False)
    start = int(rng.integers(0, n_refs - n_frames))
    noise = rng.integers(-20, 21, (n_frames, 24, 48))
    frames = np.clip(refs[start : start + n_frames].astype(int) + noise, 0, 255).astype(np.uint8)
    return refs, frames


def _run_route(problem, threads=1):
    refs, frames = problem
    localizer = route.RouteLocalizer(refs, prepared=True, threads=threads)
    return [(u.index, u.ref, u.score) for u in (localizer.update(f, prepared=True) for f in frames)]


def _same_updates(a, b):
    assert len(a) == len(b)
    for (ia, ra, sa), (ib, rb, sb) in zip(a, b):
        assert ia == ib and ra == rb and (sa == sb or (np.isnan(sa) and np.isnan(sb)))


def test_independent_route_localizers_in_eight_threads_equal_serial():
    problems = [_route_problem(seed) for seed in range(THREADS)]
    serial = [_run_route(p) for p in problems]
    assert sum(u[1] is not None for u in serial[0]) > 40  # the streams do match
    for _ in range(2):
        with ThreadPoolExecutor(max_workers=THREADS) as pool:
            parallel = list(pool.map(_run_route, problems, [2] * THREADS))
        for got, expected in zip(parallel, serial):
            _same_updates(got, expected)


def test_route_localizers_sharing_one_reference_array():
    """Several localizers over the same (read-only) reference stack: no interference."""
    refs, _ = _route_problem(0)
    refs.setflags(write=False)
    streams = [_route_problem(seed)[1] for seed in range(THREADS)]
    serial = [_run_route((refs, frames)) for frames in streams]
    with ThreadPoolExecutor(max_workers=THREADS) as pool:
        parallel = list(pool.map(lambda frames: _run_route((refs, frames)), streams))
    for got, expected in zip(parallel, serial):
        _same_updates(got, expected)


@pytest.fixture(scope="module")
def shared_map():
    rng = np.random.default_rng(7)
    frames = rng.integers(0, 256, (150, 60, 120, 3), dtype=np.uint8)
    images = nightloc.prepare(frames)
    positions = rng.uniform(0, 10, (150, 2))
    return nightloc.ReferenceMap(images, positions, rng.uniform(-3, 3, 150)), frames


def test_shared_reference_map_matches_from_eight_threads(shared_map):
    ref_map, frames = shared_map
    before = (ref_map.images.copy(), ref_map.positions.copy(), ref_map.headings.copy())
    queries = [np.roll(frames[i], 13 * i, axis=1) for i in range(0, 150, 5)]
    serial = [ref_map.match(q, threads=1) for q in queries]
    with ThreadPoolExecutor(max_workers=THREADS) as pool:
        for _ in range(3):
            parallel = list(pool.map(lambda q: ref_map.match(q, threads=2), queries))
            for got, expected in zip(parallel, serial):
                assert got.index == expected.index
                np.testing.assert_array_equal(got.scores, expected.scores)
                np.testing.assert_array_equal(got.shifts, expected.shifts)
    for array, saved in zip((ref_map.images, ref_map.positions, ref_map.headings), before):
        np.testing.assert_array_equal(array, saved)


def _localizer_stream(seed: int, n_frames: int = 40):
    """A robot driving past the shared map's places with noisy map-frame odometry."""
    rng = np.random.default_rng(100 + seed)
    order = rng.permutation(150)[:n_frames]
    odometry = [None] + [tuple(rng.normal(0, 0.3, 2)) for _ in range(n_frames - 1)]
    return order, odometry


def _run_localizer(base, frames, stream, seq_len=5):
    order, odometry = stream
    # shares the base's grid and interpolation weights
    localizer = base.with_seq_len(seq_len) if base.method == "paper" else base.fresh()
    out = []
    for index, motion in zip(order, odometry):
        estimate = localizer.update(frames[index], motion, return_heatmap=True)
        out.append(
            (estimate.x, estimate.y, estimate.heading, estimate.ref_index, estimate.confidence, estimate.heatmap)
        )
    return out


@pytest.mark.parametrize("method", ["filter", "paper"])
def test_independent_localizers_in_eight_threads_equal_serial(shared_map, method):
    """Eight Localizers over one shared map (sharing one grid and its interpolation weights),
    each with its own stream: bit-identical estimates and heat maps (the filter's belief) to
    running them one after the other."""
    ref_map, frames = shared_map
    base = nightloc.Localizer(ref_map, method=method)
    streams = [_localizer_stream(seed) for seed in range(THREADS)]
    serial = [_run_localizer(base, frames, stream) for stream in streams]
    with ThreadPoolExecutor(max_workers=THREADS) as pool:
        parallel = list(pool.map(lambda stream: _run_localizer(base, frames, stream), streams))
    for got, expected in zip(parallel, serial):
        for a, b in zip(got, expected):
            assert a[:5] == b[:5]
            np.testing.assert_array_equal(a[5], b[5])


def test_reference_map_is_read_only(shared_map):
    ref_map, _ = shared_map
    for array in (ref_map.images, ref_map.positions, ref_map.headings):
        assert not array.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0
        with pytest.raises(ValueError, match="WRITEABLE"):
            array.setflags(write=True)  # does not own its memory through a writable base
    with pytest.raises(AttributeError):
        ref_map.images = np.zeros((1, 24, 48), np.uint8)
