"""A difference matrix reduced to a picture, band by band of query rows.

A figure of an ``(n_query, n_ref)`` matrix shows at most :data:`MAX_IMAGE_CELLS` cells per side:
a larger matrix is area-averaged, each picture cell the mean of the matrix cells it covers
(a cell covered in part weighs by the part: OpenCV's ``INTER_AREA`` along the references,
the same weights along the queries), with every non-finite
cell counted as the matrix's largest finite value (0 when it has none), so one bad cell does not
blank its neighbourhood. The average is linear, so it is accumulated band by band
(:class:`MatrixPreview`): a run on a Dask cluster draws the matrix it never held whole, each band
reduced where it was computed (:func:`preview_part`), and a matrix in memory is reduced the same
way (:func:`matrix_preview`), so both give the same picture (to rounding). Scratch memory: a few
times ``PART_CELLS`` cells.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np
import scipy.sparse

__all__ = ["MAX_IMAGE_CELLS", "MatrixPreview", "PreviewPart", "matrix_preview", "preview_part", "preview_shape"]

#: Largest side, in cells, of the picture of a matrix.
MAX_IMAGE_CELLS = 900
#: Matrix cells reduced at once (scratch memory, float64).
PART_CELLS = 1 << 19


def preview_shape(n_rows: int, n_cols: int, limit: int = MAX_IMAGE_CELLS) -> tuple[int, int]:
    """The picture's ``(rows, columns)``: each side at most ``limit``."""
    return min(n_rows, limit), min(n_cols, limit)


@functools.lru_cache(maxsize=8)
def _area_weights(n_in: int, n_out: int) -> scipy.sparse.csr_matrix:
    """``(n_out, n_in)`` weights: output cell i averages input cells over [i s, (i + 1) s),
    ``s = n_in / n_out``, each input cell weighted by its overlap with that interval over ``s``."""
    if n_out == n_in:
        return scipy.sparse.identity(n_in, format="csr", dtype=np.float64)
    scale = n_in / n_out
    rows, cols, values = [], [], []
    for j in range(n_in):
        first = int(math.floor(j / scale))
        last = min(n_out - 1, int(math.floor((j + 1) / scale - 1e-12)))
        for i in range(first, last + 1):
            overlap = min(j + 1.0, (i + 1) * scale) - max(float(j), i * scale)
            if overlap > 0:
                rows.append(i)
                cols.append(j)
                values.append(overlap / scale)
    return scipy.sparse.csr_matrix((values, (rows, cols)), shape=(n_out, n_in))


def _columns(rows: np.ndarray, out_cols: int) -> np.ndarray:
    """``rows`` (float32, finite) area-averaged along the columns to ``out_cols`` (float64)."""
    if rows.shape[1] == out_cols:
        return rows.astype(np.float64)
    size = (out_cols, rows.shape[0])  # OpenCV: (width, height); the rows stay
    return cv2.resize(np.ascontiguousarray(rows), size, interpolation=cv2.INTER_AREA).astype(np.float64)


@dataclass(frozen=True)
class PreviewPart:
    """One band's share of a picture.

    Attributes:
        first_row: the picture row of ``finite[0]``.
        finite: ``(k, columns)`` float64 weighted sums of the band's finite cells.
        missing: ``(k, columns)`` float64 summed weights of its non-finite cells.
        largest: the band's largest finite value (NaN when it has none).
    """

    first_row: int
    finite: np.ndarray
    missing: np.ndarray
    largest: float


def preview_part(band: np.ndarray, start: int, n_rows: int, limit: int = MAX_IMAGE_CELLS) -> PreviewPart:
    """The share of matrix rows ``start .. start + len(band) - 1`` (``band``, ``(rows, n_cols)``) in
    the picture of an ``(n_rows, n_cols)`` matrix."""
    n_cols = band.shape[1]
    out_rows, out_cols = preview_shape(n_rows, n_cols, limit)
    row_weights = _area_weights(n_rows, out_rows)[:, start : start + band.shape[0]].tocsr()
    touched = np.flatnonzero(row_weights.getnnz(axis=1))
    first = int(touched[0]) if touched.size else 0
    last = int(touched[-1]) + 1 if touched.size else 0
    row_weights = row_weights[first:last]
    finite_sum = np.zeros((last - first, out_cols))
    missing_sum = np.zeros((last - first, out_cols))
    largest = math.nan
    step = max(1, PART_CELLS // max(1, n_cols))
    for lo in range(0, band.shape[0], step):
        chunk = np.asarray(band[lo : lo + step], dtype=np.float32)
        weights = row_weights[:, lo : lo + step]
        low, high = float(chunk.min()), float(chunk.max())  # NaN if any cell is NaN
        if math.isfinite(low) and math.isfinite(high):
            largest = high if math.isnan(largest) else max(largest, high)
            finite_sum += weights @ _columns(chunk, out_cols)
            continue
        finite = np.isfinite(chunk)
        if finite.any():
            chunk_max = float(chunk[finite].max())
            largest = chunk_max if math.isnan(largest) else max(largest, chunk_max)
        finite_sum += weights @ _columns(np.where(finite, chunk, np.float32(0)), out_cols)
        missing_sum += weights @ _columns((~finite).astype(np.float32), out_cols)
    return PreviewPart(first, finite_sum, missing_sum, largest)


class MatrixPreview:
    """The picture of an ``(n_rows, n_cols)`` matrix, accumulated from :class:`PreviewPart`\\ s
    (any order, each row once).

    Example::

        preview = MatrixPreview(n_query, n_ref)
        for start, band in bands:
            preview.add(preview_part(band, start, n_query))
        image = preview.image()          # (<= 900, <= 900) float32
    """

    def __init__(self, n_rows: int, n_cols: int, limit: int = MAX_IMAGE_CELLS):
        self.shape = preview_shape(n_rows, n_cols, limit)
        self._finite = np.zeros(self.shape)
        self._missing = np.zeros(self.shape)
        self._largest = math.nan

    def add(self, part: PreviewPart) -> None:
        """Adds one band's share."""
        rows = slice(part.first_row, part.first_row + part.finite.shape[0])
        self._finite[rows] += part.finite
        self._missing[rows] += part.missing
        if not math.isnan(part.largest):
            self._largest = part.largest if math.isnan(self._largest) else max(self._largest, part.largest)

    def image(self) -> np.ndarray:
        """The picture, float32, rows = matrix rows."""
        fill = 0.0 if math.isnan(self._largest) else self._largest
        return (self._finite + fill * self._missing).astype(np.float32)


def matrix_preview(matrix: np.ndarray, limit: int = MAX_IMAGE_CELLS) -> np.ndarray:
    """The picture of a matrix held in memory (as :class:`MatrixPreview` builds it from bands)."""
    preview = MatrixPreview(matrix.shape[0], matrix.shape[1], limit)
    preview.add(preview_part(matrix, 0, matrix.shape[0], limit))
    return preview.image()
