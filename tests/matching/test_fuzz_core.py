"""Fuzzing the binding boundary: arbitrary arrays (dtype, rank, shape, strides, values) reach the
compiled core only when valid; everything else is a TypeError or ValueError, never a crash.

Valid inputs are checked against the numpy oracle. Under AddressSanitizer (CI's sanitizer step)
this also proves the kernels never read or write out of bounds on these inputs.
"""

from __future__ import annotations

import contextlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import nightloc
from nightloc import _core

import oracle

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize

DTYPES = [np.uint8, np.int8, np.uint16, np.int32, np.float32, np.float64, np.bool_]


@st.composite
def arrays(draw, max_rank=4):
    rank = draw(st.integers(0, max_rank))
    shape = tuple(draw(st.integers(0, 9)) for _ in range(rank))
    dtype = draw(st.sampled_from(DTYPES + [np.uint8] * 6))  # mostly uint8, to reach the kernels
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    base = rng.integers(0, 256, size=shape).astype(dtype)
    layout = draw(st.sampled_from(["c", "f", "step", "readonly", "offset"]))
    if layout == "f":
        base = np.asfortranarray(base)
    elif layout == "step" and rank >= 1:
        base = np.repeat(base, 2, axis=rank - 1)[..., ::2]
    elif layout == "readonly":
        base.setflags(write=False)
    elif layout == "offset" and base.size:
        raw = np.zeros(base.nbytes + 1, np.uint8)[1:].view(np.uint8)  # misaligned start
        if base.dtype == np.uint8:
            raw[: base.size] = base.reshape(-1)
            base = raw[: base.size].reshape(shape)
    return base


def _valid_image(a, rank):
    return (
        a.dtype == np.uint8 and a.ndim == rank and a.size > 0 and a.flags.c_contiguous and all(s > 0 for s in a.shape)
    )


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(arrays(max_rank=3), arrays(max_rank=4), st.sampled_from([None, [0], [1, 0], [0, 0], [-1], [3]]))
def test_match_and_difference_matrix_boundary(query, refs, shifts):
    try:
        result = nightloc.match(query, refs, shifts=shifts)
    except (TypeError, ValueError):
        pass
    else:
        assert _valid_image(query, 2) and _valid_image(refs, 3)
        shift_values = np.arange(refs.shape[2]) if shifts is None else np.array(shifts)
        scores, best = oracle.difference_matrix(query[None], refs, shift_values)
        np.testing.assert_array_equal(result.scores, scores[0])
        np.testing.assert_array_equal(result.shifts, best[0])
    try:
        scores, best = nightloc.difference_matrix(refs, refs, shifts=shifts, threads=2)
    except (TypeError, ValueError):
        pass
    else:
        assert _valid_image(refs, 3)
        shift_values = np.arange(refs.shape[2]) if shifts is None else np.array(shifts)
        exp_scores, exp_best = oracle.difference_matrix(refs, refs, shift_values)
        np.testing.assert_array_equal(scores, exp_scores)
        np.testing.assert_array_equal(best, exp_best)


@settings(max_examples=200, deadline=None)
@given(arrays(max_rank=4), st.integers(-2, 6), st.booleans())
def test_normalization_boundary(images, radius, wrap):
    try:
        out = nightloc.patch_normalize(images, radius=radius, wrap=wrap)
    except (TypeError, ValueError):
        pass
    else:
        assert out.shape == images.shape and out.dtype == np.uint8
        first = images if images.ndim == 2 else images[0]
        expected = oracle.patch_normalize(first, radius, wrap, nightloc.DEFAULT_PATCH_SCALE)
        np.testing.assert_array_equal(out if images.ndim == 2 else out[0], expected)
    with contextlib.suppress(TypeError, ValueError):
        nightloc.block_normalize(images, side=radius)


@settings(max_examples=200, deadline=None)
@given(arrays(max_rank=4), arrays(max_rank=4), arrays(max_rank=2), st.integers(-3, 5), st.floats(-10, 1e6))
def test_private_core_boundary(a, b, shifts, threads, divisor):
    """The private module checks its inputs on its own (it is importable, so it must be safe)."""
    shifts = shifts.astype(np.int32) if shifts.dtype != np.float64 else shifts
    for call in (
        lambda: _core.difference_matrix(a, b, shifts, threads, divisor),
        lambda: _core.difference_matrix_sums(a, b, shifts, threads),
        lambda: _core.rotational_sad(a, b, shifts, threads, divisor),
        lambda: _core.patch_normalize(a, threads, True, divisor),
        lambda: _core.block_normalize(a, threads),
    ):
        with contextlib.suppress(TypeError, ValueError):
            call()
