"""Whole-image matching (paper eqs. 2-3): rotation-invariant SAD on the compiled SIMD core.

* :mod:`~nightloc.matching.sad` — :func:`match`, :func:`rotational_sad`, :func:`difference_matrix`;
* :mod:`~nightloc.matching.simd` — which SIMD path runs, and forcing one.
"""

from __future__ import annotations

from .sad import MatchResult, ShiftTable, difference_matrix, match, rotational_sad, shift_table, shifts_to_headings
from .simd import available_simd_backends, set_simd_backend, simd_backend, use_simd_backend

__all__ = [
    "MatchResult",
    "ShiftTable",
    "available_simd_backends",
    "difference_matrix",
    "match",
    "rotational_sad",
    "set_simd_backend",
    "shift_table",
    "shifts_to_headings",
    "simd_backend",
    "use_simd_backend",
]
