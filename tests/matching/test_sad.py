"""Rotation-invariant SAD, match and difference matrix against the numpy oracle, on every path."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import nightloc

import oracle

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize


def random_stack(rng, n, h, w, low=0, high=256):
    return rng.integers(low, high, size=(n, h, w), dtype=np.uint8)


GEOMETRIES = [(24, 48), (32, 64), (1, 1), (3, 7), (5, 8), (17, 40), (24, 96), (7, 400), (64, 64), (2, 136)]


@pytest.mark.parametrize(("h", "w"), GEOMETRIES)
def test_rotational_sad_table_matches_oracle(simd_path, h, w):
    rng = np.random.default_rng(h * 1000 + w)
    refs = random_stack(rng, 13, h, w)
    query = random_stack(rng, 1, h, w)[0]
    expected = oracle.rotational_sad(query, refs, range(w))
    np.testing.assert_array_equal(nightloc.rotational_sad(query, refs), expected)


@pytest.mark.parametrize(("h", "w"), GEOMETRIES)
def test_difference_matrix_matches_oracle(simd_path, h, w):
    rng = np.random.default_rng(7 * h + w)
    refs = random_stack(rng, 21, h, w)
    queries = random_stack(rng, 5, h, w)
    refs[-1] = refs[3]  # a duplicate reference: identical scores
    scores, shifts = nightloc.difference_matrix(queries, refs, threads=2)
    exp_scores, exp_shifts = oracle.difference_matrix(queries, refs, np.arange(w))
    np.testing.assert_array_equal(scores, exp_scores)
    np.testing.assert_array_equal(shifts, exp_shifts)


def test_shift_subsets_and_order(simd_path):
    rng = np.random.default_rng(3)
    refs = random_stack(rng, 30, 24, 48)
    queries = random_stack(rng, 3, 24, 48)
    for shifts in ([0], [5, 3, 40], list(range(47, -1, -1)), list(range(0, 48, 2)), [*list(range(30)), 47]):
        exp_scores, exp_shifts = oracle.difference_matrix(queries, refs, np.array(shifts))
        scores, best = nightloc.difference_matrix(queries, refs, shifts=shifts)
        np.testing.assert_array_equal(scores, exp_scores)
        np.testing.assert_array_equal(best, exp_shifts)
        table = nightloc.rotational_sad(queries[0], refs, shifts=shifts)
        np.testing.assert_array_equal(table, oracle.rotational_sad(queries[0], refs, shifts))


def test_ties_go_to_earliest_shift_and_lowest_reference(simd_path):
    # A constant query is equally far from a column-constant reference at every shift.
    refs = np.zeros((4, 6, 16), np.uint8)
    refs[:, :, :] = np.arange(16, dtype=np.uint8)[None, None, :] * 3
    query = np.full((6, 16), 20, np.uint8)
    shifts = [9, 2, 5]
    result = nightloc.match(np.tile(np.arange(16, dtype=np.uint8) * 0 + 20, (6, 1)), refs, shifts=shifts)
    assert result.index == 0
    assert np.all(result.shifts == 9)
    # Uniform images: every shift ties -> the first of the default order, 0.
    flat = nightloc.match(query, np.full((3, 6, 16), 7, np.uint8))
    assert flat.index == 0 and np.all(flat.shifts == 0)


def test_match_on_threads_ties_go_to_lowest_reference_across_chunks(simd_path):
    """Two threads split the references into chunks; the best of each chunk is merged: the
    lowest (sum, index) must win wherever the tied copies land (copies near both ends)."""
    rng = np.random.default_rng(5)
    refs = random_stack(rng, 1500, 24, 48)  # 8.3e7 comparisons: two threads take part
    query = random_stack(rng, 1, 24, 48)[0]
    for copies in ([1499, 1200, 901], [7, 1498], [0, 749, 750, 1499]):
        tied = refs.copy()
        for k, place in enumerate(copies):
            tied[place] = np.roll(query, 3 + k, axis=1)  # each a zero-difference match
        expected_scores, expected_shifts = oracle.difference_matrix(query[None], tied, np.arange(48))
        for threads in (1, 2):
            result = nightloc.match(query, tied, threads=threads)
            assert result.index == min(copies)
            np.testing.assert_array_equal(result.scores, expected_scores[0])
            np.testing.assert_array_equal(result.shifts, expected_shifts[0])
            headings = 2 * np.pi * expected_shifts[0] / 48
            np.testing.assert_allclose(result.headings, np.where(headings > np.pi, headings - 2 * np.pi, headings))


def test_extreme_values_do_not_overflow(simd_path):
    # 0 against 255 everywhere: the largest possible sums (16-bit lanes and flushes inside).
    for h, w in ((24, 48), (64, 64), (96, 128)):
        refs = np.full((9, h, w), 255, np.uint8)
        query = np.zeros((h, w), np.uint8)
        result = nightloc.match(query, refs)
        assert np.all(result.scores == 255.0)
        table = nightloc.rotational_sad(query, refs)
        assert np.all(table == 255.0)


def test_match_shift_and_heading_convention(simd_path):
    """query = ref rolled right by d columns -> shift d, heading +2*pi*d/W (query = ref + heading)."""
    rng = np.random.default_rng(11)
    refs = nightloc.patch_normalize(random_stack(rng, 40, 24, 48))
    for place, d in ((17, 5), (3, 0), (39, 47), (20, 24), (0, 40)):
        query = np.roll(refs[place], d, axis=1)
        result = nightloc.match(query, refs)
        assert result.index == place
        assert result.shift == d
        assert result.score == 0.0
        expected = 2 * np.pi * d / 48
        expected = expected - 2 * np.pi if expected > np.pi else expected
        assert result.heading == pytest.approx(expected)
        assert -np.pi < result.heading <= np.pi


def test_headings_wrap_into_half_open_interval():
    headings = nightloc.shifts_to_headings(np.array([0, 12, 24, 36, 47]), 48)
    np.testing.assert_allclose(headings, [0, np.pi / 2, np.pi, -np.pi / 2, -2 * np.pi / 48])


def test_match_reports_all_fields():
    rng = np.random.default_rng(5)
    refs = random_stack(rng, 10, 24, 48)
    result = nightloc.match(refs[4], refs)
    assert result.index == 4 and result.score == 0.0 and result.width == 48
    assert result.scores.shape == (10,) and result.scores.dtype == np.float32
    assert result.shifts.shape == (10,) and result.shifts.dtype == np.int32
    assert result.headings.shape == (10,) and result.headings.dtype == np.float64
    exp_scores, exp_shifts = oracle.difference_matrix(refs[4:5], refs, np.arange(48))
    np.testing.assert_array_equal(result.scores, exp_scores[0])
    np.testing.assert_array_equal(result.shifts, exp_shifts[0])


@pytest.mark.parametrize("threads", [1, 2, 3, 8])
def test_threads_give_identical_results(threads):
    rng = np.random.default_rng(9)
    refs = random_stack(rng, 3000, 24, 48)
    queries = random_stack(rng, 4, 24, 48)
    serial = nightloc.difference_matrix(queries, refs, threads=1)
    parallel = nightloc.difference_matrix(queries, refs, threads=threads)
    np.testing.assert_array_equal(serial[0], parallel[0])
    np.testing.assert_array_equal(serial[1], parallel[1])
    one = nightloc.match(queries[0], refs, threads=threads)
    np.testing.assert_array_equal(one.scores, serial[0][0])


def test_large_reference_set_against_oracle():
    """Several tiles and reference chunks: checked against the vectorized numpy formulation."""
    rng = np.random.default_rng(21)
    refs = random_stack(rng, 2500, 24, 48)
    queries = random_stack(rng, 20, 24, 48)
    scores, shifts = nightloc.difference_matrix(queries, refs, threads=2)
    for m in (0, 7, 19):
        sums = oracle.best_numpy_rotational_sums(queries[m], refs)
        best = np.argmin(sums, axis=1)
        np.testing.assert_array_equal(shifts[m], best)
        np.testing.assert_array_equal(scores[m], oracle.scores_from_sums(sums[np.arange(len(refs)), best], 1152))


def test_forward_camera_difference_matrix_nordland_size(simd_path):
    rng = np.random.default_rng(2)
    refs = random_stack(rng, 40, 32, 64)
    queries = random_stack(rng, 6, 32, 64)
    scores, shifts = nightloc.difference_matrix(queries, refs, shifts=[0])
    exp_scores, _ = oracle.difference_matrix(queries, refs, np.array([0]))
    np.testing.assert_array_equal(scores, exp_scores)
    assert np.all(shifts == 0)


_VNNI_OFF_SCRIPT = """
import sys
import numpy as np
import nightloc
sys.path.insert(0, sys.argv[1])
import oracle
rng = np.random.default_rng(5)
for h, w in ((24, 48), (64, 64), (7, 400), (33, 96)):
    refs = rng.integers(0, 256, size=(11, h, w), dtype=np.uint8)
    refs[0] = 255
    query = rng.integers(0, 256, size=(h, w), dtype=np.uint8)
    for q in (query, np.zeros_like(query)):
        np.testing.assert_array_equal(nightloc.rotational_sad(q, refs), oracle.rotational_sad(q, refs, range(w)))
        scores, shifts = nightloc.difference_matrix(q[None], refs, threads=1)
        exp_scores, exp_shifts = oracle.difference_matrix(q[None], refs, np.arange(w))
        np.testing.assert_array_equal(scores, exp_scores)
        np.testing.assert_array_equal(shifts, exp_shifts)
print("ok", nightloc.simd_backend(), nightloc._core.avx512_sad_variant()[0])
"""


@pytest.mark.skipif("avx512bw" not in nightloc.available_simd_backends(), reason="needs a CPU with AVX-512BW")
def test_avx512_kernel_without_vnni_matches_oracle():
    """NIGHTLOC_AVX512_VNNI=0 selects the vpaddw all-shift kernel (CPUs without VNNI) in a fresh process."""
    env = dict(os.environ, NIGHTLOC_AVX512_VNNI="0", NIGHTLOC_SIMD="avx512bw")
    done = subprocess.run(
        [sys.executable, "-c", _VNNI_OFF_SCRIPT, str(Path(__file__).resolve().parents[1])],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["ok", "avx512bw", "vpaddw"]


@pytest.mark.skipif("avx512bw" not in nightloc.available_simd_backends(), reason="needs a CPU with AVX-512BW")
@pytest.mark.parametrize("variant", ["vpaddw", "vnni"])
def test_each_avx512_variant_matches_oracle(variant):
    """Both accumulations of the all-shift kernel, forced in this process, give the oracle's sums."""
    from nightloc import _core

    if variant not in _core.available_avx512_sad_variants():
        pytest.skip(f"this CPU cannot run the {variant} variant")
    rng = np.random.default_rng(11)
    refs = random_stack(rng, 13, 24, 48)
    refs[0] = 255
    query = rng.integers(0, 256, size=(24, 48), dtype=np.uint8)
    _core.set_avx512_sad_variant(variant)
    try:
        with nightloc.use_simd_backend("avx512bw"):
            assert _core.avx512_sad_variant() == (variant, "forced by set_avx512_sad_variant")
            table = nightloc.rotational_sad(query, refs)
            scores, shifts = nightloc.difference_matrix(query[None], refs, threads=2)
    finally:
        _core.set_avx512_sad_variant(None)
    np.testing.assert_array_equal(table, oracle.rotational_sad(query, refs, range(48)))
    exp_scores, exp_shifts = oracle.difference_matrix(query[None], refs, np.arange(48))
    np.testing.assert_array_equal(scores, exp_scores)
    np.testing.assert_array_equal(shifts, exp_shifts)


def test_avx512_variant_says_why():
    from nightloc import _core

    found = _core.avx512_sad_variant()
    if "avx512bw" not in nightloc.available_simd_backends():
        assert found is None
        return
    name, reason = found
    assert name in _core.available_avx512_sad_variants()
    assert reason.startswith(("measured at first use", "CPU table", "NIGHTLOC_AVX512_VNNI", "this CPU has no"))
    with pytest.raises(ValueError, match="expected vpaddw or vnni"):
        _core.set_avx512_sad_variant("fast")
