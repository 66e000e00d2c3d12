"""Fuzzing route mode's binding boundary (contrast enhancement, trajectory search, the
difference-matrix row writer): arbitrary arrays and parameters reach the compiled core only when
valid, everything else is a TypeError or ValueError, and valid calls equal the numpy oracle.

Values include NaN, infinities and float32's extremes; shapes include empty and one-column
matrices; layouts include Fortran order, strides, read-only and misaligned buffers. Run under
AddressSanitizer in CI's sanitizer step, this also shows the C++ never reads or writes outside
its arrays on these inputs.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nightloc import _core

import route_oracle

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize

SPECIAL = [np.nan, np.inf, -np.inf, 0.0, -0.0, 3.4e38, -3.4e38, 1e-45]


@st.composite
def matrices(draw, max_rows=9, max_cols=14):
    rows = draw(st.integers(0, max_rows))
    cols = draw(st.integers(0, max_cols))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    values = rng.uniform(0, 5, (rows, cols))
    if values.size and draw(st.booleans()):
        count = draw(st.integers(1, max(1, values.size // 3)))
        values.flat[rng.integers(0, values.size, count)] = rng.choice(SPECIAL, count)
    dtype = draw(st.sampled_from([np.float32] * 5 + [np.float64, np.float16, np.int32]))
    with np.errstate(over="ignore", invalid="ignore"):  # float16/int32 of 3.4e38 or NaN
        matrix = values.astype(dtype)
    layout = draw(st.sampled_from(["c", "c", "f", "step", "readonly", "misaligned", "3d"]))
    if layout == "f":
        matrix = np.asfortranarray(matrix)
    elif layout == "step" and cols:
        matrix = np.repeat(matrix, 2, axis=1)[:, ::2]
    elif layout == "readonly":
        matrix.setflags(write=False)
    elif layout == "misaligned" and matrix.dtype == np.float32 and matrix.size:
        raw = np.zeros(matrix.nbytes + 1, np.uint8)[1:]
        view = raw.view(np.float32).reshape(matrix.shape) if raw.ctypes.data % 4 == 0 else None
        if view is None:  # numpy refuses a misaligned float view: copy through bytes instead
            view = np.frombuffer(raw[: matrix.nbytes], dtype=np.float32).reshape(matrix.shape)
            view = view.copy()
        matrix = view
    elif layout == "3d":
        matrix = matrix[None]
    return matrix


def _valid_matrix(m, min_cols=1, min_rows=1):
    """What the private core accepts (the public wrappers also refuse empty matrices)."""
    return (
        m.dtype == np.float32
        and m.ndim == 2
        and m.flags.c_contiguous
        and m.shape[0] >= min_rows
        and m.shape[1] >= min_cols
    )


def _same(a, b):
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    matrices(),
    st.integers(-2, 2**31 - 1) | st.integers(-2, 8),
    st.sampled_from(["none", "bound", "global_min", "x"]),
    st.integers(-1, 3),
)
def test_enhance_contrast_boundary(d, radius, offset, threads):
    try:
        out, _added = _core.enhance_contrast(d, radius, offset, threads)
    except (TypeError, ValueError):
        assert not (_valid_matrix(d, 2, 0) and radius >= 1 and offset in ("none", "bound", "global_min"))
        return
    assert _valid_matrix(d, 2, 0) and radius >= 1
    assert out.shape == d.shape and out.dtype == np.float32
    if radius <= 50 and np.isfinite(d).all():
        with np.errstate(over="ignore", invalid="ignore"):  # float32's extremes overflow, as in the core
            expected = route_oracle.enhance_zscores(d, radius)
        if offset == "bound":
            expected = (expected + np.float32(_core.zscore_bound(radius))).astype(np.float32)
        if offset in ("none", "bound"):
            np.testing.assert_allclose(out, expected, rtol=0, atol=1e-5, equal_nan=True)
    else:
        assert out.shape == d.shape  # NaN/inf in, no crash out


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    matrices(max_rows=14, max_cols=16),
    st.integers(2, 7) | st.integers(-1, 1),
    st.sampled_from([0.8, 1.0, 0.5]) | st.sampled_from([2.0, 0.0, -1.0, math.nan, math.inf, 1e-300, 1000.0, 1001.0]),
    st.sampled_from([1.2, 1.0, 2.0]) | st.sampled_from([0.5, math.nan, math.inf, 1000.0]),
    st.integers(0, 4) | st.just(-1),
    st.booleans(),
    st.integers(0, 5) | st.integers(-2, 16),
    st.integers(5, 14) | st.integers(-2, 16),
    st.integers(-1, 3),
)
def test_trajectory_search_boundary(dd, ds, vmin, vmax, uniqueness, causal, begin, end, threads):
    try:
        refs, scores = _core.trajectory_search(dd, ds, vmin, vmax, uniqueness, causal, begin, end, threads)
    except (TypeError, ValueError):
        return
    assert _valid_matrix(dd, 1, 0) and ds >= 2 and 0 < vmin <= vmax <= 1000 and uniqueness >= 0
    assert 0 <= begin <= end <= dd.shape[0]
    n_query, n_ref = dd.shape
    assert refs.shape == scores.shape == (n_query,)
    assert ((refs >= -1) & (refs < n_ref)).all()
    assert (refs[:begin] == -1).all() and (refs[end:] == -1).all()
    if vmax <= 3 and vmin >= 0.5:  # the oracle's speed list is short there
        find = route_oracle.find_matches_causal if causal else route_oracle.find_matches_centred
        ds_oracle = ds  # the oracle rounds a centred ds up to even itself
        expected_refs, expected_scores = find(dd, ds_oracle, vmin, vmax, 2 * uniqueness)
        _same(refs[begin:end], expected_refs[begin:end])
        np.testing.assert_array_equal(scores[begin:end], expected_scores[begin:end])


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.integers(0, 2**31),
    st.integers(1, 12),
    st.integers(2, 16),
    st.integers(2, 6),
    st.sampled_from([(0.8, 1.2), (1.0, 1.0), (0.5, 2.0), (1.0, 3.0)]),
    st.integers(0, 3),
    st.booleans(),
    st.floats(0, 0.5),
)
def test_trajectory_search_equals_the_oracle_on_hostile_values(
    seed, n_query, n_ref, ds, speeds, uniqueness, causal, holes
):
    """Valid parameters, matrices salted with NaN, infinities and float32's extremes: the core's
    matches and uniqueness ratios equal OpenSeqSLAM's semantics (the numpy oracle) exactly."""
    uniqueness = min(uniqueness, (n_ref - 2) // 2)  # the core needs n_ref >= 2 * uniqueness + 2
    rng = np.random.default_rng(seed)
    dd = rng.uniform(0, 5, (n_query, n_ref)).astype(np.float32)
    salt = rng.random(dd.shape) < holes
    dd[salt] = rng.choice(np.array(SPECIAL, np.float32), int(salt.sum()))
    refs, scores = _core.trajectory_search(dd, ds, *speeds, uniqueness, causal, 0, n_query, 1)
    find = route_oracle.find_matches_causal if causal else route_oracle.find_matches_centred
    with np.errstate(all="ignore"):
        expected_refs, expected_scores = find(dd, ds, *speeds, 2 * uniqueness)
    _same(refs, expected_refs)
    np.testing.assert_array_equal(scores, expected_scores)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.integers(1, 4),
    st.integers(1, 6),
    st.integers(1, 5),
    st.integers(1, 9),
    st.sampled_from(["ok", "wrong shape", "read-only", "float64", "strided", "none"]),
    st.sampled_from([1.0, 0.0, -1.0, math.nan, math.inf, 1152.0]),
    st.sampled_from([[0], [0, 1], [], [-1], [99], [2, 2]]),
)
def test_difference_matrix_into_boundary(n_query, n_ref, height, width, out_kind, divisor, shifts):
    rng = np.random.default_rng(n_query * 100 + n_ref * 10 + width)
    queries = rng.integers(0, 256, (n_query, height, width), dtype=np.uint8)
    refs = rng.integers(0, 256, (n_ref, height, width), dtype=np.uint8)
    out = {
        "ok": np.full((n_query, n_ref), -7, np.float32),
        "wrong shape": np.zeros((n_query + 1, n_ref), np.float32),
        "read-only": np.zeros((n_query, n_ref), np.float32),
        "float64": np.zeros((n_query, n_ref)),
        "strided": np.zeros((n_query, 2 * n_ref), np.float32)[:, ::2],
        "none": None,
    }[out_kind]
    if out_kind == "read-only":
        out.setflags(write=False)
    shift_array = np.array(shifts, dtype=np.int32)
    try:
        _core.difference_matrix_into(queries, refs, shift_array, 1, divisor, out)
    except (TypeError, ValueError):
        return
    assert out is not None and out.dtype == np.float32 and out.shape == (n_query, n_ref)
    assert out.flags.c_contiguous and out.flags.writeable  # (a 1 x 1 strided view is contiguous)
    assert divisor > 0 and math.isfinite(divisor)
    assert shift_array.size and len(set(shifts)) == len(shifts) and all(0 <= s < width for s in shifts)
    sums = np.stack([route_oracle_sums(q, refs, shifts) for q in queries])
    np.testing.assert_array_equal(out, (sums.astype(np.float64) / divisor).astype(np.float32))


def route_oracle_sums(query, refs, shifts):
    """min over ``shifts`` of sum |roll(query, -k) - ref| for every reference (int64)."""
    q = query.astype(np.int64)
    return np.min(
        [np.abs(refs.astype(np.int64) - np.roll(q, -k, axis=1)[None]).sum(axis=(1, 2)) for k in shifts], axis=0
    )
