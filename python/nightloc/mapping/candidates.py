"""Which pairs of frames become visual constraints, and their measured relative headings.

Two kinds of pairs see the same place:

* **sequence** pairs: a frame and the next ``sequence_window`` frames of the drive, while the
  current pose estimate puts them at most ``max_distance`` apart;
* **place** pairs (revisits, loop closures): for every frame, the ``place_candidates`` frames
  farther along (or back) the drive whose images match it best (lowest whole-image score of
  :func:`nightloc.difference_matrix`), kept when the current estimate puts them at most
  ``max_distance`` apart, or when the match is *strong* (score at most ``strong_score``: the two
  images were taken at about one spot, whatever the drifted estimate says).

Each kept pair is measured (:func:`nightloc.mapping.visual.relative_heading`, the axis between
the two places from the current estimate) into a :class:`VisualConstraint` whose heading
standard deviation grows with the distance between the places (parallax); strong place pairs
also constrain the relative position (the two places coincide, ``place_position_std``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .visual import relative_heading

__all__ = ["CandidatePair", "VisualConstraint", "candidate_pairs", "measure_constraints"]


@dataclass(frozen=True)
class CandidatePair:
    """Frames ``i < j`` that may see the same place; ``kind`` ``"sequence"`` or ``"place"``."""

    i: int
    j: int
    kind: str
    score: float


@dataclass(frozen=True)
class VisualConstraint:
    """A measured relation between frames ``i < j``.

    Attributes:
        i, j: frame indices.
        heading: ``heading_j - heading_i`` measured by the images, radians in (-pi, pi].
        heading_std: its standard deviation, radians.
        score: whole-image match score (mean absolute difference, lower = more alike).
        kind: ``"sequence"`` or ``"place"``.
        position_std: metres, for a strong place pair (the two places coincide); else None.
    """

    i: int
    j: int
    heading: float
    heading_std: float
    score: float
    kind: str
    position_std: float | None = None


def candidate_pairs(
    scores: np.ndarray,
    poses: np.ndarray,
    *,
    sequence_window: int,
    max_distance: float,
    place_candidates: int,
    strong_score: float,
) -> tuple[list[CandidatePair], int]:
    """The pairs worth measuring, and how many candidates the distance gate dropped.

    Args:
        scores: ``(N, N)`` whole-image scores of every frame against every frame.
        poses: ``(N, 3)`` current pose estimate (x, y, heading).
        sequence_window, max_distance, place_candidates, strong_score: see the module text.
    """
    n = len(poses)
    positions = np.asarray(poses, dtype=np.float64)[:, :2]
    pairs: dict[tuple[int, int], CandidatePair] = {}
    dropped = 0
    for i in range(n - 1):
        for j in range(i + 1, min(n, i + sequence_window + 1)):
            if np.hypot(*(positions[j] - positions[i])) <= max_distance:
                pairs[(i, j)] = CandidatePair(i, j, "sequence", float(scores[i, j]))
            else:
                dropped += 1
    if place_candidates > 0 and n > sequence_window + 1:
        masked = np.array(scores, dtype=np.float64, copy=True)
        index = np.arange(n)
        masked[np.abs(index[:, None] - index[None, :]) <= sequence_window] = np.inf
        count = min(place_candidates, n - 1)
        best = np.argpartition(masked, count - 1, axis=1)[:, :count]
        for i in range(n):
            for j in best[i]:
                score = float(masked[i, j])
                if not math.isfinite(score):
                    continue
                key = (min(i, int(j)), max(i, int(j)))
                if key in pairs:
                    continue
                near = np.hypot(*(positions[key[1]] - positions[key[0]])) <= max_distance
                if near or score <= strong_score:
                    pairs[key] = CandidatePair(key[0], key[1], "place", score)
                else:
                    dropped += 1
    return sorted(pairs.values(), key=lambda p: (p.i, p.j)), dropped


def measure_constraints(
    images: np.ndarray,
    pairs: list[CandidatePair],
    poses: np.ndarray,
    *,
    heading_std: float,
    heading_std_per_metre: float,
    axis_half_width: float,
    strong_score: float,
    place_position_std: float,
    min_axis_distance: float = 0.1,
) -> list[VisualConstraint]:
    """Measures the relative heading of every pair (see the module text).

    Args:
        images: ``(N, H, W)`` prepared panoramas.
        pairs: from :func:`candidate_pairs`.
        poses: ``(N, 3)`` current estimate: the distance and the axis between the two places.
        min_axis_distance: metres; closer places are compared over every column.
    """
    out = []
    for pair in pairs:
        i, j = pair.i, pair.j
        dx, dy = poses[j, :2] - poses[i, :2]
        distance = math.hypot(dx, dy)
        strong = pair.kind == "place" and pair.score <= strong_score
        axis = None if distance < min_axis_distance or strong else math.atan2(dy, dx) - poses[i, 2]
        prior = None if strong else poses[j, 2] - poses[i, 2]
        heading, score = relative_heading(images[j], images[i], axis, axis_half_width, prior=prior)
        spread = 0.0 if strong else distance  # a strong pair's places coincide
        out.append(
            VisualConstraint(
                i,
                j,
                heading,
                heading_std + heading_std_per_metre * spread,
                score,
                pair.kind,
                place_position_std if strong else None,
            )
        )
    return out
