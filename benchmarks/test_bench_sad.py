"""Throughput of the rotation-invariant SAD (eqs. 2-3): numpy oracle vs the compiled core.

One 48x24 query against N references at all 48 shifts = N * 55 296 byte comparisons. Each
group holds the best vectorized numpy formulation and the core (1 thread, 2 threads, every SIMD
path, both accumulations of the AVX-512 all-shift kernel beside the per-CPU default);
`extra_info["G_per_s"]` is byte comparisons per second (10^9). Results are asserted equal.

    python -m pytest benchmarks --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import nightloc
from nightloc import _core
from nightloc._core import ALL_SIMD_BACKENDS as ALL_BACKENDS  # every path the core knows

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import oracle

H, W = 24, 48
SIZES = [50, 500, 5000, pytest.param(50000, marks=pytest.mark.slow)]
_cache = {}


def problem(n):
    if n not in _cache:
        rng = np.random.default_rng(n)
        refs = nightloc.patch_normalize(rng.integers(0, 256, size=(n, H, W), dtype=np.uint8))
        query = np.roll(refs[n // 3], 7, axis=1)
        expected = oracle.best_numpy_rotational_sums(query, refs) if n <= 5000 else None
        _cache.clear()
        _cache[n] = (query, refs, expected)
    return _cache[n]


def record(benchmark, n):
    benchmark.extra_info["byte_comparisons"] = n * H * W * W
    stats = getattr(benchmark, "stats", None)
    if stats is not None and stats.stats.min > 0:
        benchmark.extra_info["G_per_s"] = round(n * H * W * W / stats.stats.min / 1e9, 2)


@pytest.mark.parametrize("n", SIZES)
def test_numpy_oracle(benchmark, n):
    query, refs, expected = problem(n)
    benchmark.group = f"rotational SAD, N={n}"
    sums = benchmark.pedantic(oracle.best_numpy_rotational_sums, args=(query, refs), rounds=1 if n >= 5000 else 3)
    record(benchmark, n)
    assert np.argmin(sums.min(axis=1)) == n // 3
    if expected is not None:
        np.testing.assert_array_equal(sums, expected)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("n", SIZES)
def test_core(benchmark, n, threads):
    query, refs, expected = problem(n)
    benchmark.group = f"rotational SAD, N={n}"
    result = benchmark(nightloc.match, query, refs, threads=threads)
    record(benchmark, n)
    assert result.index == n // 3 and result.shift == 7
    if expected is not None:
        best = np.argmin(expected, axis=1)
        np.testing.assert_array_equal(result.shifts, best)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_core_simd_paths(benchmark, backend):
    if backend not in nightloc.available_simd_backends():
        pytest.skip(f"this CPU does not support {backend}")
    n = 500
    query, refs, expected = problem(n)
    benchmark.group = f"rotational SAD by SIMD path, N={n}, 1 thread"
    with nightloc.use_simd_backend(backend):
        result = benchmark(nightloc.match, query, refs, threads=1)
    record(benchmark, n)
    np.testing.assert_array_equal(result.shifts, np.argmin(expected, axis=1))


@pytest.mark.parametrize("variant", ["default", "vpaddw", "vnni"])
@pytest.mark.parametrize("n", [500, 5000])
def test_core_avx512_variants(benchmark, n, variant):
    """The avx512bw all-shift kernel's accumulations, forced, beside the one chosen for this CPU."""
    if "avx512bw" not in nightloc.available_simd_backends():
        pytest.skip("this CPU does not support avx512bw")
    if variant != "default" and variant not in _core.available_avx512_sad_variants():
        pytest.skip(f"this CPU cannot run the {variant} variant")
    query, refs, expected = problem(n)
    chosen = _core.avx512_sad_variant()
    benchmark.group = f"AVX-512 all-shift variants, N={n}, 1 thread"
    benchmark.extra_info["variant"] = chosen[0] if variant == "default" else variant
    benchmark.extra_info["default_reason"] = chosen[1]
    _core.set_avx512_sad_variant(None if variant == "default" else variant)
    try:
        with nightloc.use_simd_backend("avx512bw"):
            result = benchmark(nightloc.match, query, refs, threads=1)
    finally:
        _core.set_avx512_sad_variant(None)
    record(benchmark, n)
    np.testing.assert_array_equal(result.shifts, np.argmin(expected, axis=1))


def test_patch_normalize_speed(benchmark):
    rng = np.random.default_rng(0)
    images = rng.integers(0, 256, size=(1000, H, W), dtype=np.uint8)
    benchmark.group = "patch normalization, 1000 images 48x24"
    out = benchmark(nightloc.patch_normalize, images)
    assert out.shape == images.shape


# ---- the translation window ----------------------------------------------------------------
#
# One 48x24 query against N = 500 references: the rotational kernel (48 circular shifts),
# a panorama with a row window (48 shifts x +-2 rows) and a forward camera with a column and row
# window (+-8 columns x +-2 rows), each on every SIMD path, beside a vectorized numpy version of
# the window. G/s counts the byte comparisons of the overlaps (what a candidate compares), so the
# window's G/s compares with the rotational kernel's.

WINDOW_CASES = {
    "rotational 48 shifts": (None, (0, 0)),
    "panorama, rows +-2": (None, (0, 2)),
    "forward, columns +-8 rows +-1": ([0], (8, 1)),
    "forward, columns +-8 rows +-2 (route default)": ([0], (8, 2)),
}


def overlap_comparisons(shifts, window) -> int:
    columns, rows = window
    n_shifts = W if shifts is None else len(shifts)
    total = 0
    for dy in range(-rows, rows + 1):
        if columns:
            total += sum((H - abs(dy)) * (W - abs(dx)) for dx in range(-columns, columns + 1))
        else:
            total += (H - abs(dy)) * W * n_shifts
    return total


def numpy_window_scores(query: np.ndarray, refs: np.ndarray, shifts, window) -> np.ndarray:
    """Vectorized numpy: the best mean over the window's candidates for each reference (float64),
    |a - b| = a + b - 2 min(a, b) on uint8 slices, uint32 sums."""
    columns, rows = window
    q = query
    best = np.full(len(refs), np.inf)
    values = range(-columns, columns + 1) if columns else (range(W) if shifts is None else shifts)
    for dy in range(-rows, rows + 1):
        r0, r1 = max(0, -dy), min(H, H - dy)
        for value in values:
            if columns:
                c0, c1 = max(0, -value), min(W, W - value)
                part_q = q[r0 + dy : r1 + dy, c0 + value : c1 + value]
                part_r = refs[:, r0:r1, c0:c1]
            else:
                part_q = np.roll(q, -value, axis=1)[r0 + dy : r1 + dy]
                part_r = refs[:, r0:r1]
            low = np.minimum(part_r, part_q[None])
            sums = (
                part_r.sum(axis=(1, 2), dtype=np.uint32)
                + np.uint32(part_q.sum(dtype=np.uint32))
                - 2 * low.sum(axis=(1, 2), dtype=np.uint32)
            )
            np.minimum(best, sums / part_q.size, out=best)
    return best


def record_window(benchmark, n, shifts, window):
    comparisons = n * overlap_comparisons(shifts, window)
    benchmark.extra_info["byte_comparisons"] = comparisons
    stats = getattr(benchmark, "stats", None)
    if stats is not None and stats.stats.min > 0:
        benchmark.extra_info["G_per_s"] = round(comparisons / stats.stats.min / 1e9, 2)


@pytest.mark.parametrize("case", sorted(WINDOW_CASES))
def test_window_numpy(benchmark, case):
    shifts, window = WINDOW_CASES[case]
    query, refs, _ = problem(500)
    benchmark.group = "translation window, N=500, 1 thread"
    best = benchmark.pedantic(numpy_window_scores, args=(query, refs, shifts, window), rounds=1)
    record_window(benchmark, 500, shifts, window)
    result = nightloc.match(query, refs, shifts, threads=1, shift_window=window)
    np.testing.assert_array_equal(result.scores, best.astype(np.float32))


@pytest.mark.parametrize("backend", ALL_BACKENDS)
@pytest.mark.parametrize("case", sorted(WINDOW_CASES))
def test_window_core(benchmark, case, backend):
    if backend not in nightloc.available_simd_backends():
        pytest.skip(f"this CPU does not support {backend}")
    shifts, window = WINDOW_CASES[case]
    query, refs, _ = problem(500)
    benchmark.group = "translation window, N=500, 1 thread"
    benchmark.extra_info["simd_path"] = backend
    with nightloc.use_simd_backend(backend):
        result = benchmark(nightloc.match, query, refs, shifts, threads=1, shift_window=window)
    record_window(benchmark, 500, shifts, window)
    assert result.index == 500 // 3 and result.scores[result.index] == 0.0


@pytest.mark.parametrize("case", ["panorama, rows +-2", "forward, columns +-8 rows +-2 (route default)"])
def test_window_difference_matrix(benchmark, case):
    """The route's batch: 200 queries x 2000 references, 2 threads."""
    shifts, window = WINDOW_CASES[case]
    _, refs, _ = problem(5000)
    queries, refs = refs[:200], refs[200:2200]
    benchmark.group = "translation window, difference matrix 200 x 2000, 2 threads"
    scores, _ = benchmark.pedantic(
        nightloc.difference_matrix,
        args=(queries, refs, shifts),
        kwargs={"threads": 2, "shift_window": window},
        rounds=2,
    )
    comparisons = 200 * 2000 * overlap_comparisons(shifts, window)
    stats = getattr(benchmark, "stats", None)
    if stats is not None and stats.stats.min > 0:
        benchmark.extra_info["G_per_s"] = round(comparisons / stats.stats.min / 1e9, 2)
    assert scores.shape == (200, 2000)
