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
