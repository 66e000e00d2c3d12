"""The translation window (viewpoint tolerance) against the numpy oracle, on every SIMD path.

Window 0 must give the outputs of the core as it was before the window existed (a golden file
written by that core, tools/sad_golden.py), and every window the oracle's: the exact mean over the
overlap, ties in the documented order, scores float32(double(sum) / overlap).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import nightloc
from nightloc import _core

import oracle

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import sad_golden

pytestmark = pytest.mark.sanitize

GOLDEN = Path(__file__).parent / "data" / "sad_golden.npz"


def random_stack(rng, n, h, w, high=256):
    return rng.integers(0, high, size=(n, h, w), dtype=np.uint8)


# ---- window 0 is today's core, bit for bit ------------------------------------------------------


@pytest.mark.parametrize("case_index", range(len(sad_golden.CASES)))
def test_window_zero_equals_the_core_before_the_window(simd_path, case_index):
    golden = np.load(GOLDEN)
    name = sad_golden.CASES[case_index][0]
    queries, refs, shifts, divisor = sad_golden.case_inputs(case_index)
    for window in (None, (0, 0)):
        scores, best, rows = _core.difference_matrix(queries, refs, shifts, 2, divisor, window or (0, 0))
        np.testing.assert_array_equal(scores, golden[f"{name}/scores"])
        np.testing.assert_array_equal(best, golden[f"{name}/best_shifts"])
        assert not rows.any()
        table = _core.rotational_sad(queries[0], refs, shifts, 2, divisor, window or (0, 0))
        np.testing.assert_array_equal(table, golden[f"{name}/table"])
        result = nightloc.match(queries[0], refs, shifts, threads=2, shift_window=window)
        assert result.index == golden[f"{name}/match_index"]
        np.testing.assert_array_equal(result.scores, golden[f"{name}/match_scores"])
        np.testing.assert_array_equal(result.shifts, golden[f"{name}/match_shifts"])
        np.testing.assert_array_equal(result.headings, golden[f"{name}/match_headings"])
    if divisor == 0.0:
        scores, best = nightloc.difference_matrix(queries, refs, shifts, threads=1, shift_window=(0, 0))
        np.testing.assert_array_equal(scores, golden[f"{name}/scores"])
        np.testing.assert_array_equal(best, golden[f"{name}/best_shifts"])


# ---- windows against the oracle -----------------------------------------------------------------

# (height, width, shifts (None: all), window (columns, rows), value range)
WINDOW_CASES = [
    (24, 48, None, (0, 2), 256),  # a panorama with a row window (the 2D filter's use)
    (24, 48, [0], (8, 2), 256),  # a forward camera (route mode)
    (24, 48, [0], (3, 0), 256),
    (24, 48, [0], (0, 3), 256),
    (24, 48, [5, 3, 40, 0], (0, 1), 256),  # a shift subset, unsorted
    (24, 48, [0], (47, 23), 256),  # the widest window: one-pixel overlaps at the corners
    (24, 48, None, (0, 23), 256),
    (3, 7, [0], (6, 2), 256),  # tiny, width not a multiple of 8
    (5, 12, None, (0, 4), 2),  # binary images: many equal means across overlaps
    (6, 16, [0], (5, 3), 2),
    (17, 40, [0], (9, 4), 4),
    (7, 400, None, (0, 3), 256),  # many shifts: the plans take several blocks of shifts
    (200, 200, [0], (9, 2), 256),  # a large image: blocks of column offsets
]


@pytest.mark.parametrize(("h", "w", "shifts", "window", "high"), WINDOW_CASES)
def test_difference_matrix_matches_oracle(simd_path, h, w, shifts, window, high):
    rng = np.random.default_rng(h * 7919 + w * 31 + window[0] * 7 + window[1])
    n_refs = 9 if h * w > 10000 else 21
    refs = random_stack(rng, n_refs, h, w, high)
    queries = random_stack(rng, 3, h, w, high)
    refs[-1] = refs[2]
    shift_list = list(range(w)) if shifts is None else shifts
    exp_scores, exp_values, exp_rows = oracle.window_difference_matrix(queries, refs, shift_list, window)
    for threads in (1, 2):
        rows = np.zeros((3, n_refs), np.int32)
        scores, values = nightloc.difference_matrix(
            queries, refs, shifts, threads=threads, shift_window=window, rows_out=rows
        )
        np.testing.assert_array_equal(scores, exp_scores)
        np.testing.assert_array_equal(values, exp_values)
        np.testing.assert_array_equal(rows, exp_rows)


@pytest.mark.parametrize(("h", "w", "shifts", "window", "high"), WINDOW_CASES)
def test_table_and_match_match_oracle(simd_path, h, w, shifts, window, high):
    rng = np.random.default_rng(h * 31 + w * 7 + window[0] * 3 + window[1])
    n_refs = 7 if h * w > 10000 else 17
    refs = random_stack(rng, n_refs, h, w, high)
    query = random_stack(rng, 1, h, w, high)[0]
    shift_list = list(range(w)) if shifts is None else shifts
    table = nightloc.matching.shift_table(query, refs, shifts, threads=2, shift_window=window)
    exp_scores, exp_rows = oracle.window_table(query, refs, shift_list, window)
    np.testing.assert_array_equal(table.scores, exp_scores)
    np.testing.assert_array_equal(table.rows, exp_rows)
    expected_columns = np.arange(-window[0], window[0] + 1) if window[0] else np.array(shift_list)
    np.testing.assert_array_equal(table.columns, expected_columns)
    np.testing.assert_array_equal(nightloc.rotational_sad(query, refs, shifts, shift_window=window), exp_scores)

    result = nightloc.match(query, refs, shifts, threads=2, shift_window=window)
    m_scores, m_values, m_rows = oracle.window_difference_matrix(query[None], refs, shift_list, window)
    np.testing.assert_array_equal(result.scores, m_scores[0])
    np.testing.assert_array_equal(result.shifts, m_values[0])
    np.testing.assert_array_equal(result.rows, m_rows[0])
    assert result.index == oracle.window_best_reference(query, refs, shift_list, window)
    np.testing.assert_array_equal(result.headings, nightloc.shifts_to_headings(m_values[0], w))


def test_divisor_scales_with_the_overlap(simd_path):
    rng = np.random.default_rng(5)
    refs = random_stack(rng, 12, 24, 48)
    queries = random_stack(rng, 4, 24, 48)
    shifts = np.array([0], np.int32)
    for divisor in (37.0, 1152.0, 0.5):
        scores, values, rows = _core.difference_matrix(queries, refs, shifts, 1, divisor, (6, 2))
        exp_scores, exp_values, exp_rows = oracle.window_difference_matrix(queries, refs, [0], (6, 2), divisor)
        np.testing.assert_array_equal(scores, exp_scores)
        np.testing.assert_array_equal(values, exp_values)
        np.testing.assert_array_equal(rows, exp_rows)
    # divisor = pixels is the mean over the overlap, as divisor 0
    by_pixels = _core.difference_matrix(queries, refs, shifts, 1, 1152.0, (6, 2))[0]
    np.testing.assert_array_equal(by_pixels, _core.difference_matrix(queries, refs, shifts, 1, 0.0, (6, 2))[0])
    out = np.empty((4, 12), np.float32)
    _core.difference_matrix_into(queries, refs, shifts, 2, 37.0, out, (6, 2))
    np.testing.assert_array_equal(out, oracle.window_difference_matrix(queries, refs, [0], (6, 2), 37.0)[0])


# ---- geometry: signs, borders, ties -------------------------------------------------------------


def moved(image: np.ndarray, down: int, right: int) -> np.ndarray:
    """The image content moved down and right (uncovered pixels filled with other values)."""
    out = np.roll(image, (down, right), axis=(0, 1))
    return out


@pytest.mark.parametrize(("down", "right"), [(0, 0), (2, 5), (-1, -7), (1, 8), (-2, 3)])
def test_a_moved_query_is_found_at_its_offset(simd_path, down, right):
    rng = np.random.default_rng(11)
    ref = rng.integers(0, 256, size=(24, 48), dtype=np.uint8)
    query = moved(ref, down, right)  # wrapped borders differ from the reference's content there
    result = nightloc.match(query, ref[None], shifts=[0], threads=1, shift_window=(8, 2))
    assert (int(result.shifts[0]), int(result.rows[0])) == (right, down)
    assert result.scores[0] == 0.0  # over the overlap the pixels are the same
    panorama = nightloc.match(query, ref[None], threads=1, shift_window=(0, 2))
    assert (int(panorama.shifts[0]), int(panorama.rows[0])) == (right % 48, down)
    assert panorama.scores[0] == 0.0


def test_overlaps_at_the_borders(simd_path):
    """The extreme offsets compare a single row or column; the score is that strip's mean."""
    rng = np.random.default_rng(2)
    query = rng.integers(0, 256, size=(6, 10), dtype=np.uint8)
    ref = rng.integers(0, 256, size=(6, 10), dtype=np.uint8)
    table = nightloc.matching.shift_table(query, ref[None], shifts=[0], shift_window=(9, 0))
    for dx in (-9, 9, -3, 4):
        overlap_q = query[:, max(0, dx) : 10 + min(0, dx)].astype(int)
        overlap_r = ref[:, max(0, -dx) : 10 - max(0, dx)].astype(int)
        expected = np.float32(np.abs(overlap_q - overlap_r).sum() / overlap_q.size)
        assert table.scores[0, dx + 9] == expected
    rows_only = nightloc.matching.shift_table(query, ref[None], shifts=[0], shift_window=(0, 5))
    strip = np.abs(query[5].astype(int) - ref[0].astype(int)).sum() / 10  # dy = +5: query row 5 vs ref row 0
    other = np.abs(query[0].astype(int) - ref[5].astype(int)).sum() / 10  # dy = -5
    full = np.abs(query.astype(int) - ref.astype(int)).sum() / 60
    means = {5: strip, -5: other, 0: full}
    best_dy = int(rows_only.rows[0, 0])
    if best_dy in means:
        assert rows_only.scores[0, 0] == np.float32(means[best_dy])


def test_ties_go_to_small_offsets_negative_first(simd_path):
    flat = np.full((1, 8, 16), 9, np.uint8)
    result = nightloc.match(flat[0], flat, shifts=[0], shift_window=(4, 3))
    assert (int(result.shifts[0]), int(result.rows[0])) == (0, 0)
    # Horizontal stripes one row apart: dy = -1 and +1 both match exactly; -1 wins.
    stripes = (np.arange(8)[:, None] % 2 * 100 + np.zeros((8, 16), int)).astype(np.uint8)
    query = np.roll(stripes, 1, axis=0)
    result = nightloc.match(query, stripes[None], shifts=[0], shift_window=(4, 3))
    assert (int(result.shifts[0]), int(result.rows[0]), float(result.scores[0])) == (0, -1, 0.0)
    panorama = nightloc.match(query, stripes[None], shifts=[3, 0, 5], shift_window=(0, 3))
    assert (int(panorama.shifts[0]), int(panorama.rows[0])) == (3, -1)  # the shift list's first
    # Vertical stripes: dx = -1 and +1 tie; -1 wins.
    columns = stripes.T[:8, :8].copy()
    result = nightloc.match(np.roll(columns, 1, axis=1), columns[None], shifts=[0], shift_window=(3, 0))
    assert (int(result.shifts[0]), int(result.rows[0])) == (-1, 0)


def test_windows_wider_than_the_image_are_refused():
    rng = np.random.default_rng(0)
    refs = random_stack(rng, 3, 24, 48)
    with pytest.raises(ValueError, match="row window of \\+-24 rows is not smaller than the image height"):
        nightloc.match(refs[0], refs, shifts=[0], shift_window=(0, 24))
    with pytest.raises(ValueError, match="column window of \\+-48 columns"):
        nightloc.difference_matrix(refs, refs, shifts=[0], shift_window=(48, 0))
    with pytest.raises(ValueError, match="non-wrapping"):
        nightloc.rotational_sad(refs[0], refs, shift_window=(2, 0))
    with pytest.raises(ValueError, match="non-wrapping"):
        nightloc.match(refs[0], refs, shifts=[0, 1], shift_window=(2, 0))
    with pytest.raises(ValueError, match=">= 0"):
        nightloc.match(refs[0], refs, shift_window=(0, -1))
    with pytest.raises(TypeError, match="pair"):
        nightloc.match(refs[0], refs, shift_window=3)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=">= 0"):
        _core.difference_matrix(refs, refs, np.array([0], np.int32), 1, 0.0, (-1, 0))
    with pytest.raises(ValueError, match="not smaller"):
        _core.shift_table(refs[0], refs, np.array([0], np.int32), 1, 0.0, (1 << 40, 0))
