"""Whole-image matching: rotation-invariant sums of absolute differences (paper eqs. 2-3).

Conventions (see ``docs/design.md``):

* Images are ``uint8``; one image is ``(height, width)``, a stack ``(n, height, width)``,
  C-contiguous. Wrong dtype, rank or size raises TypeError/ValueError; nothing is cast.
* **Shift** ``k`` (0 <= k < width) compares the query rolled *left* by ``k`` columns,
  ``numpy.roll(query, -k, axis=1)``, with the reference. If the query is the reference rolled
  right by ``d`` columns (``query = numpy.roll(ref, d, axis=1)``) the best shift is ``d``.
* **Heading**: panorama column ``c`` looks along world azimuth ``heading - 2*pi*c/width``, so a
  best shift ``k`` means the query's heading is the reference's heading **plus**
  ``2*pi*k/width``, reported wrapped to (-pi, pi]. ``query_heading = ref_heading + headings[i]``.
* Scores are mean absolute differences in grey levels, ``float32(double(sum) / (h*w))``:
  lower is more similar. Difference matrices are ``(n_query, n_ref)``.

**Translation window** (``shift_window=(columns, rows)``, viewpoint tolerance: a robot a few
metres beside its day path sees the scene moved by a few pixels). On top of the column shifts,
row offsets ``dy`` in ``-rows .. rows`` are tried; for a forward camera (``shifts=[0]``, images
that do not wrap) column offsets ``dx`` in ``-columns .. columns`` too (a panorama's columns are
searched by its circular shifts, so ``columns`` must be 0 there). Candidate ``(dx or k, dy)``
compares ``query[r + dy, c + dx]`` (or ``c + k`` modulo the width) with ``ref[r, c]`` over the
*overlap*, the pixels where both exist; its score is the mean over the overlap,
``float32(double(sum) / overlap)``, so that shifts compare fairly. The best candidate has the
lowest mean (compared exactly as fractions); equal means go to row offsets ``0, -1, +1, -2, ...``
first, then to the shift list's order (circular) or column offsets ``0, -1, +1, ...``. If the
query is the reference moved down by ``d`` rows and right by ``e`` columns the best candidate is
``dy = d``, ``dx = e``. ``shift_window=(0, 0)`` (the default) is the plain search, bit for bit.
An offset as large as the image (no overlap) is a ValueError.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from .._validate import ShiftSpec, WindowSpec, same_image_size, shift_list, thread_count, uint8_array
from .._validate import shift_window as shift_window_of

__all__ = [
    "MatchResult",
    "ShiftTable",
    "difference_matrix",
    "match",
    "rotational_sad",
    "shift_table",
    "shifts_to_headings",
]


def shifts_to_headings(shifts: np.ndarray, width: int) -> np.ndarray:
    """Relative headings (radians, in (-pi, pi]) of column shifts of a ``width``-column panorama."""
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
        raise ValueError(f"width must be an int >= 1 (columns per 360 degrees), got {width!r}")
    angles = 2.0 * np.pi * np.asarray(shifts, dtype=np.float64) / float(width)
    return np.where(angles > np.pi, angles - 2.0 * np.pi, angles)


def rotational_sad(
    query: np.ndarray,
    refs: np.ndarray,
    shifts: ShiftSpec = None,
    threads: int | None = 1,
    shift_window: WindowSpec = None,
) -> np.ndarray:
    """The full table of eq. (2): mean absolute difference at every shift.

    Args:
        query: ``(H, W)`` uint8 prepared image.
        refs: ``(N, H, W)`` uint8 prepared images.
        shifts: the column shifts to try (default all ``0..W-1``; ``[0]`` for forward cameras).
        threads: worker threads (None: all cores).
        shift_window: ``(columns, rows)`` translation window (module docstring); each entry is
            then the best over the row offsets, and with ``columns > 0`` the table's columns are
            the column offsets ``-columns .. columns`` (:func:`shift_table` also gives the rows).

    Returns:
        float32 ``(N, n_shifts)``: ``table[i, j]`` compares ``numpy.roll(query, -shifts[j], 1)``
        with ``refs[i]``.
    """
    return shift_table(query, refs, shifts, threads, shift_window).scores


@dataclass(frozen=True)
class ShiftTable:
    """Scores of one query against N references for every column candidate, each the best over
    the translation window's row offsets (:func:`shift_table`).

    Attributes:
        scores: ``(N, n_columns)`` float32 mean absolute differences over the overlap.
        rows: ``(N, n_columns)`` int32 row offset ``dy`` of each entry (0 without a row window).
        columns: ``(n_columns,)`` int32, what each column stands for: the circular shift ``k``
            (the shift list) or, for a forward camera with a column window, the offset ``dx``.
    """

    scores: np.ndarray
    rows: np.ndarray
    columns: np.ndarray


def shift_table(
    query: np.ndarray,
    refs: np.ndarray,
    shifts: ShiftSpec = None,
    threads: int | None = 1,
    shift_window: WindowSpec = None,
) -> ShiftTable:
    """:func:`rotational_sad` with the best row offset of each entry and the column candidates.

    A panorama with a row window gives one column per heading (its shifts), each the best over
    the rows; a forward camera (``shifts=[0]``) with a column window ``(c, r)`` one column per
    offset ``dx = -c .. c`` (a heading offset of ``dx`` pixels of the field of view).
    """
    q = uint8_array(query, 2, "query")
    r = uint8_array(refs, 3, "refs")
    same_image_size(q, r, "query", "refs")
    window = shift_window_of(shift_window)
    shift_array = shift_list(shifts, r.shape[2])
    scores, rows = _core.shift_table(q, r, shift_array, thread_count(threads), 0.0, window)
    if window[0] > 0:
        columns = np.arange(-window[0], window[0] + 1, dtype=np.int32)
    else:
        columns = np.array(shift_array, dtype=np.int32)
    return ShiftTable(scores=scores, rows=rows, columns=columns)


@dataclass(frozen=True)
class MatchResult:
    """One query matched against N references (eq. 3).

    Attributes:
        index: the best reference (lowest score; ties go to the lowest index).
        scores: ``(N,)`` float32, minimum over shifts of the mean absolute difference.
        shifts: ``(N,)`` int32, the column shift attaining it (ties: earliest in the shift list);
            with a column window (forward camera), the column offset ``dx``.
        headings: ``(N,)`` float64 radians in (-pi, pi]: query heading minus reference heading.
        width: image width in pixels (columns per 360 degrees).
        rows: ``(N,)`` int32 row offset ``dy`` of the best candidate (0 without a row window),
            or None when the result was made without one.
    """

    index: int
    scores: np.ndarray
    shifts: np.ndarray
    headings: np.ndarray
    width: int
    rows: np.ndarray | None = None

    @property
    def score(self) -> float:
        """Score of the best reference."""
        return float(self.scores[self.index])

    @property
    def shift(self) -> int:
        """Column shift of the best reference."""
        return int(self.shifts[self.index])

    @property
    def heading(self) -> float:
        """Query heading relative to the best reference (radians, in (-pi, pi])."""
        return float(self.headings[self.index])


def match(
    query: np.ndarray,
    refs: np.ndarray,
    shifts: ShiftSpec = None,
    threads: int | None = None,
    shift_window: WindowSpec = None,
) -> MatchResult:
    """Rotation-invariant match of one prepared query against prepared references.

    Args:
        query: ``(H, W)`` uint8.
        refs: ``(N, H, W)`` uint8.
        shifts: column shifts to search (default all; ``[0]`` for a forward camera).
        threads: worker threads (default all cores; small problems run on one).
        shift_window: ``(columns, rows)`` translation window (module docstring).

    Returns:
        :class:`MatchResult`.
    """
    q = uint8_array(query, 2, "query")
    r = uint8_array(refs, 3, "refs")
    same_image_size(q, r, "query", "refs")
    window = shift_window_of(shift_window)
    index, scores, best_shifts, headings, rows = _core.match(
        q, r, shift_list(shifts, r.shape[2]), thread_count(threads), window
    )
    return MatchResult(
        index=index, scores=scores, shifts=best_shifts, headings=headings, width=int(r.shape[2]), rows=rows
    )


def difference_matrix(
    queries: np.ndarray,
    refs: np.ndarray,
    shifts: ShiftSpec = None,
    threads: int | None = None,
    shift_window: WindowSpec = None,
    rows_out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Batch difference matrix: every query against every reference, minimum over shifts.

    References stream through cache once per block of queries; memory beyond the two outputs is
    a few hundred KB per thread.

    Args:
        queries: ``(M, H, W)`` uint8.
        refs: ``(N, H, W)`` uint8.
        shifts: column shifts to search (default all; ``[0]`` for a forward camera).
        threads: worker threads (default all cores).
        shift_window: ``(columns, rows)`` translation window (module docstring).
        rows_out: optional writable int32 ``(M, N)`` array that receives the best row offsets.

    Returns:
        ``(scores, shifts)``: float32 ``(M, N)`` mean absolute differences (lower = more similar)
        and int32 ``(M, N)`` best shifts (the column offsets ``dx`` with a column window); rows
        are queries, columns references.
    """
    q = uint8_array(queries, 3, "queries")
    r = uint8_array(refs, 3, "refs")
    same_image_size(q, r, "queries", "refs")
    if rows_out is not None:
        if not isinstance(rows_out, np.ndarray) or rows_out.dtype != np.int32 or rows_out.shape != (len(q), len(r)):
            raise ValueError(f"rows_out must be an int32 array of shape {(len(q), len(r))}")
        if not rows_out.flags.writeable:
            raise ValueError("rows_out must be writable")
    window = shift_window_of(shift_window)
    scores, best_shifts, rows = _core.difference_matrix(
        q, r, shift_list(shifts, r.shape[2]), thread_count(threads), 0.0, window
    )
    if rows_out is not None:
        rows_out[...] = rows
    return scores, best_shifts
