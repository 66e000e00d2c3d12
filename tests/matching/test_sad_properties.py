"""Property tests (hypothesis): random shapes, values and shift lists against the numpy oracle."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import nightloc

import oracle


@st.composite
def problems(draw):
    h = draw(st.integers(1, 12))
    w = draw(st.integers(1, 40))
    n = draw(st.integers(1, 12))
    m = draw(st.integers(1, 3))
    seed = draw(st.integers(0, 2**32 - 1))
    levels = draw(st.sampled_from([2, 4, 256]))  # few grey levels make ties likely
    rng = np.random.default_rng(seed)
    queries = rng.integers(0, levels, size=(m, h, w), dtype=np.uint8) * (255 // (levels - 1))
    refs = rng.integers(0, levels, size=(n, h, w), dtype=np.uint8) * (255 // (levels - 1))
    shifts = draw(st.one_of(st.none(), st.permutations(list(range(w))).map(lambda p: p[: max(1, len(p) // 2)])))
    backend = draw(st.sampled_from(nightloc.available_simd_backends()))
    return queries.astype(np.uint8), refs.astype(np.uint8), shifts, backend


@settings(max_examples=150, deadline=None)
@given(problems())
def test_difference_matrix_equals_oracle(problem):
    queries, refs, shifts, backend = problem
    shift_values = np.arange(refs.shape[2]) if shifts is None else np.array(shifts)
    with nightloc.use_simd_backend(backend):
        scores, best = nightloc.difference_matrix(queries, refs, shifts=shifts, threads=2)
        table = nightloc.rotational_sad(queries[0], refs, shifts=shifts)
    exp_scores, exp_best = oracle.difference_matrix(queries, refs, shift_values)
    np.testing.assert_array_equal(scores, exp_scores)
    np.testing.assert_array_equal(best, exp_best)
    np.testing.assert_array_equal(table, oracle.rotational_sad(queries[0], refs, shift_values))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 12), st.integers(1, 30), st.integers(0, 5), st.booleans(), st.integers(0, 2**32 - 1))
def test_patch_normalize_equals_oracle(h, w, radius, wrap, seed):
    image = np.random.default_rng(seed).integers(0, 256, size=(h, w), dtype=np.uint8)
    np.testing.assert_array_equal(
        nightloc.patch_normalize(image, radius=radius, wrap=wrap),
        oracle.patch_normalize(image, radius, wrap, nightloc.DEFAULT_PATCH_SCALE),
    )


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 47), st.integers(0, 2**32 - 1))
def test_rolled_reference_is_found_with_its_shift(d, seed):
    rng = np.random.default_rng(seed)
    refs = nightloc.patch_normalize(rng.integers(0, 256, size=(8, 24, 48), dtype=np.uint8))
    result = nightloc.match(np.roll(refs[5], d, axis=1), refs)
    assert (result.index, result.shift, result.score) == (5, d, 0.0)
