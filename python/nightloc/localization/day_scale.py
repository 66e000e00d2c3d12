"""Learned appearances as evidence about their day images (experience maps, docs/experience_maps.md).

A learned appearance belongs to a *day reference*: the day reference of its place nearest in
heading (:func:`learned_proxies`; none for a place learned in a gap of the day map). Per frame,
before the per-place minimum:

1. the learned references' scores are multiplied by ``median(day minimum scores) /
   median(learned minimum scores)`` of the frame (a night frame scores lower against any night
   image than against a day image: they share the night's noise and darkness);
2. each day reference with learned ones is moved by how far the best of their minimum scores
   lies from the median of that over all day references with learned ones: a place whose night
   look matches better than the typical place's scores lower, one that matches worse higher, so
   the night looks add evidence without favouring the places that have one;
3. a learned reference then scores as its day reference (and the filter reads it at that
   reference's heading): the day images keep the geometry between places and the headings, and a
   night look, taken at one pose with a heading the learning night only estimated, cannot pull
   the estimate towards where it was taken.

A learned reference in a gap keeps step 1. The grid filter in the core does the same
(``GridFilterMap::learned``); a map with no learned reference, or with nothing but learned ones,
is left as it is.
"""

from __future__ import annotations

import math

import numpy as np

from ..mapping.reference_map import ReferenceMap

__all__ = ["learned_mask", "learned_proxies", "on_day_scale"]


def learned_mask(ref_map: ReferenceMap) -> np.ndarray | None:
    """``(N,)`` uint8, 1 for each reference learned on a night, 0 for the day map's; None when
    the map has no learned reference (a day map: its scores are never rescaled)."""
    appearances = ref_map.appearances
    if appearances is None:
        return None
    learned = (np.asarray(appearances.night) > 0).astype(np.uint8)
    return learned if learned.any() else None


def learned_proxies(learned: np.ndarray, place_of_ref: np.ndarray, headings: np.ndarray | None) -> np.ndarray:
    """``(N,)`` int: for each learned reference the day reference it is evidence about, the day
    reference of its place nearest in heading (ties: the first; no headings: the first), -1 when
    its place has none (and for the day references)."""
    mask = np.asarray(learned, dtype=bool)
    place = np.asarray(place_of_ref)
    out = np.full(len(mask), -1, dtype=np.int64)
    day_refs: dict[int, list[int]] = {}
    for d in np.flatnonzero(~mask):
        day_refs.setdefault(int(place[d]), []).append(int(d))
    for i in np.flatnonzero(mask):
        candidates = day_refs.get(int(place[i]), [])
        if not candidates:
            continue
        if headings is None:
            out[i] = candidates[0]
            continue
        gaps = [abs(math.remainder(float(headings[d]) - float(headings[i]), 2 * math.pi)) for d in candidates]
        out[i] = candidates[int(np.argmin(gaps))]
    return out


def on_day_scale(scores: np.ndarray, learned: np.ndarray | None, proxies: np.ndarray | None) -> np.ndarray:
    """A frame's scores ``(N,)`` (or its table ``(N, shifts)``, a row per reference) with the
    learned references' evidence moved onto their day references (steps 1-3 above), in the scores'
    dtype (float32: rounded as the core rounds). ``learned``: :func:`learned_mask` (None: the
    scores themselves); ``proxies``: :func:`learned_proxies` (None: every look in a gap)."""
    s = np.asarray(scores)
    if learned is None:
        return s
    mask = np.asarray(learned, dtype=bool)
    proxy = np.asarray(proxies if proxies is not None else np.full(len(mask), -1))
    if mask.shape != (s.shape[0],) or proxy.shape != (s.shape[0],):
        raise ValueError(
            f"learned and proxies must hold one value per reference ({s.shape[0]}), "
            f"got shapes {mask.shape} and {proxy.shape}"
        )
    if mask.all() or not mask.any():
        return s
    mins = (s if s.ndim == 1 else s.min(axis=1)).astype(np.float64)
    day, night = float(np.median(mins[~mask])), float(np.median(mins[mask]))
    if not (day > 0 and night > 0):
        return s
    out = s.copy()
    scaled = (mins * (day / night)).astype(s.dtype)  # step 1, rounded as stored
    gap = mask & (proxy < 0)
    out[gap] = (s[gap].astype(np.float64) * (day / night)).astype(s.dtype)
    evidence = np.full(len(mask), np.inf, dtype=s.dtype)
    with_proxy = np.flatnonzero(mask & (proxy >= 0))
    np.minimum.at(evidence, proxy[with_proxy], scaled[with_proxy])
    covered = np.flatnonzero(np.isfinite(evidence))
    if covered.size:
        neutral = float(np.median(evidence[covered].astype(np.float64)))
        move = evidence[covered].astype(np.float64) - neutral
        moved = out[covered].astype(np.float64) + (move if out.ndim == 1 else move[:, None])
        out[covered] = moved.astype(s.dtype)  # step 2
        out[with_proxy] = out[proxy[with_proxy]]  # step 3
    return out
