"""The picture of a difference matrix: area averages as OpenCV's INTER_AREA, the same whether
the matrix is reduced whole or band by band."""

from __future__ import annotations

import cv2
import numpy as np

from nightloc.route.preview import MatrixPreview, matrix_preview, preview_part


def test_large_matrices_are_area_averaged_with_bad_cells_as_the_largest_value():
    rng = np.random.default_rng(1)
    matrix = rng.random((1800, 2700), dtype=np.float32)
    matrix[5, 7] = np.inf  # counted as the finite maximum
    matrix[900, 13] = np.nan
    clean = matrix.copy()
    clean[~np.isfinite(matrix)] = matrix[np.isfinite(matrix)].max()
    np.testing.assert_allclose(
        matrix_preview(matrix, limit=900), clean.reshape(900, 2, 900, 3).mean(axis=(1, 3)), rtol=1e-6
    )
    small = rng.random((40, 30), dtype=np.float32)
    np.testing.assert_array_equal(matrix_preview(small, limit=900), small)


def test_fractional_cells_weigh_as_opencv_inter_area():
    rng = np.random.default_rng(2)
    matrix = rng.random((1234, 2017), dtype=np.float32)
    expected = cv2.resize(matrix, (900, 900), interpolation=cv2.INTER_AREA)
    np.testing.assert_allclose(matrix_preview(matrix), expected, rtol=2e-5, atol=2e-6)


def test_bands_in_any_order_give_the_picture_of_the_whole():
    rng = np.random.default_rng(3)
    matrix = rng.normal(size=(2333, 1500)).astype(np.float32)
    matrix[rng.integers(0, 2333, 40), rng.integers(0, 1500, 40)] = np.nan
    preview = MatrixPreview(*matrix.shape)
    starts = list(range(0, 2333, 97))
    for start in reversed(starts):
        preview.add(preview_part(matrix[start : start + 97], start, matrix.shape[0]))
    np.testing.assert_allclose(preview.image(), matrix_preview(matrix), rtol=1e-6, atol=1e-6)
    empty = MatrixPreview(3, 4)
    empty.add(preview_part(np.full((3, 4), np.nan, np.float32), 0, 3))
    np.testing.assert_array_equal(empty.image(), np.zeros((3, 4), np.float32))  # no finite value: 0
