"""Learned appearances' scores on the day map's scale (experience maps, docs/experience_maps.md).

A night frame scores lower against any night image than against a day image: the two share the
night's noise and darkness. Taken as they are, a place that owns a learned night look would win
over a place that has only its day image, even where the day image is the better match; and a
night look, sharp but taken at one pose, would snap the estimate onto the places that have one.
Per frame, before the per-place minimum, a learned reference's scores are therefore

1. multiplied by ``median(day minimum scores) / median(learned minimum scores)`` of the frame;
2. raised by ``1 - LEARNED_ADVANTAGE`` of how far their minimum lies below the best day
   reference of the same place (a place without a day reference: step 1 only).

The grid filter in the core does the same (``GridFilterMap::learned``); a map with no learned
reference, or with nothing but learned ones, is left as it is.
"""

from __future__ import annotations

import numpy as np

from ..mapping.reference_map import ReferenceMap

__all__ = ["LEARNED_ADVANTAGE", "learned_mask", "on_day_scale"]

#: The share of a learned appearance's lead over the best day image of its place that counts
#: (the core's ``kLearnedAdvantage``; chosen by the sweep in docs/experience_maps.md).
LEARNED_ADVANTAGE = 0.4


def learned_mask(ref_map: ReferenceMap) -> np.ndarray | None:
    """``(N,)`` uint8, 1 for each reference learned on a night, 0 for the day map's; None when
    the map has no learned reference (a day map: its scores are never rescaled)."""
    appearances = ref_map.appearances
    if appearances is None:
        return None
    learned = (np.asarray(appearances.night) > 0).astype(np.uint8)
    return learned if learned.any() else None


def on_day_scale(scores: np.ndarray, learned: np.ndarray | None, place_of_ref: np.ndarray) -> np.ndarray:
    """A frame's scores ``(N,)`` (or its table ``(N, shifts)``, a row per reference) with the
    learned references' brought onto the day scale (steps 1 and 2 above), in the scores' dtype
    (float32: rounded as the core rounds). ``learned``: :func:`learned_mask` (None: the scores
    themselves); ``place_of_ref``: ``(N,)`` each reference's place
    (:attr:`~nightloc.localization.heatmap.HeatMapper.place_of_ref`)."""
    s = np.asarray(scores)
    if learned is None:
        return s
    mask = np.asarray(learned, dtype=bool)
    place = np.asarray(place_of_ref)
    if mask.shape != (s.shape[0],) or place.shape != (s.shape[0],):
        raise ValueError(
            f"learned and place_of_ref must hold one value per reference ({s.shape[0]}), "
            f"got shapes {mask.shape} and {place.shape}"
        )
    if mask.all() or not mask.any():
        return s
    mins = s if s.ndim == 1 else s.min(axis=1)
    day, night = (float(np.median(mins[k].astype(np.float64))) for k in (~mask, mask))
    if not (day > 0 and night > 0):
        return s
    out = s.copy()
    out[mask] = (s[mask].astype(np.float64) * (day / night)).astype(s.dtype)
    scaled = out if out.ndim == 1 else out.min(axis=1)
    day_best = np.full(int(place.max()) + 1, np.inf)
    np.minimum.at(day_best, place[~mask], scaled[~mask].astype(np.float64))
    best = day_best[place]
    leads = mask & np.isfinite(best) & (scaled < best)
    lift = np.where(leads, (1.0 - LEARNED_ADVANTAGE) * (best - scaled.astype(np.float64)), 0.0)
    rows = np.flatnonzero(lift > 0)
    lifted = out[rows].astype(np.float64) + (lift[rows] if out.ndim == 1 else lift[rows, None])
    out[rows] = lifted.astype(s.dtype)
    return out
