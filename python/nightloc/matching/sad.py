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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from .._validate import ShiftSpec, same_image_size, shift_list, thread_count, uint8_array

__all__ = [
    "MatchResult",
    "difference_matrix",
    "match",
    "rotational_sad",
    "shifts_to_headings",
]


def shifts_to_headings(shifts: np.ndarray, width: int) -> np.ndarray:
    """Relative headings (radians, in (-pi, pi]) of column shifts of a ``width``-column panorama."""
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
        raise ValueError(f"width must be an int >= 1 (columns per 360 degrees), got {width!r}")
    angles = 2.0 * np.pi * np.asarray(shifts, dtype=np.float64) / float(width)
    return np.where(angles > np.pi, angles - 2.0 * np.pi, angles)


def rotational_sad(
    query: np.ndarray, refs: np.ndarray, shifts: ShiftSpec = None, threads: int | None = 1
) -> np.ndarray:
    """The full table of eq. (2): mean absolute difference at every shift.

    Args:
        query: ``(H, W)`` uint8 prepared image.
        refs: ``(N, H, W)`` uint8 prepared images.
        shifts: the column shifts to try (default all ``0..W-1``; ``[0]`` for forward cameras).
        threads: worker threads (None: all cores).

    Returns:
        float32 ``(N, n_shifts)``: ``table[i, j]`` compares ``numpy.roll(query, -shifts[j], 1)``
        with ``refs[i]``.
    """
    q = uint8_array(query, 2, "query")
    r = uint8_array(refs, 3, "refs")
    same_image_size(q, r, "query", "refs")
    return _core.rotational_sad(q, r, shift_list(shifts, r.shape[2]), thread_count(threads))


@dataclass(frozen=True)
class MatchResult:
    """One query matched against N references (eq. 3).

    Attributes:
        index: the best reference (lowest score; ties go to the lowest index).
        scores: ``(N,)`` float32, minimum over shifts of the mean absolute difference.
        shifts: ``(N,)`` int32, the column shift attaining it (ties: earliest in the shift list).
        headings: ``(N,)`` float64 radians in (-pi, pi]: query heading minus reference heading.
        width: image width in pixels (columns per 360 degrees).
    """

    index: int
    scores: np.ndarray
    shifts: np.ndarray
    headings: np.ndarray
    width: int

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


def match(query: np.ndarray, refs: np.ndarray, shifts: ShiftSpec = None, threads: int | None = None) -> MatchResult:
    """Rotation-invariant match of one prepared query against prepared references.

    Args:
        query: ``(H, W)`` uint8.
        refs: ``(N, H, W)`` uint8.
        shifts: column shifts to search (default all; ``[0]`` for a forward camera).
        threads: worker threads (default all cores; small problems run on one).

    Returns:
        :class:`MatchResult`.
    """
    q = uint8_array(query, 2, "query")
    r = uint8_array(refs, 3, "refs")
    same_image_size(q, r, "query", "refs")
    index, scores, best_shifts, headings = _core.match(q, r, shift_list(shifts, r.shape[2]), thread_count(threads))
    return MatchResult(index=index, scores=scores, shifts=best_shifts, headings=headings, width=int(r.shape[2]))


def difference_matrix(
    queries: np.ndarray, refs: np.ndarray, shifts: ShiftSpec = None, threads: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Batch difference matrix: every query against every reference, minimum over shifts.

    References stream through cache once per block of queries; memory beyond the two outputs is
    a few hundred KB per thread.

    Args:
        queries: ``(M, H, W)`` uint8.
        refs: ``(N, H, W)`` uint8.
        shifts: column shifts to search (default all; ``[0]`` for a forward camera).
        threads: worker threads (default all cores).

    Returns:
        ``(scores, shifts)``: float32 ``(M, N)`` mean absolute differences (lower = more similar)
        and int32 ``(M, N)`` best shifts; rows are queries, columns references.
    """
    q = uint8_array(queries, 3, "queries")
    r = uint8_array(refs, 3, "refs")
    same_image_size(q, r, "queries", "refs")
    return _core.difference_matrix(q, r, shift_list(shifts, r.shape[2]), thread_count(threads))
