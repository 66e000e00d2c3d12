"""Which pairs of frames become visual constraints, and their measured relative headings.

Two kinds of pairs see the same place:

* **sequence** pairs: a frame and the next ``sequence_window`` frames of the drive, while the
  current pose estimate puts them at most ``max_distance`` apart;
* **place** pairs (revisits, loop closures): for every frame, the ``place_candidates`` frames
  farther along (or back) the drive whose images match it best (lowest whole-image score of
  :func:`nightloc.difference_matrix`), kept when the current estimate puts them at most
  ``max_distance`` apart plus three standard deviations of their positions (a drifted estimate
  of frames far apart in the drive is not trusted to rule a revisit out), or when the match is
  *strong* (score at most ``strong_score``: the two images were taken at about one spot).

Each kept pair is measured (:func:`nightloc.mapping.visual.relative_heading`, the axis between
the two places from the current estimate) into a :class:`VisualConstraint` whose heading
standard deviation grows with the distance between the places (parallax); strong place pairs
also constrain the relative position (the two places coincide, ``place_position_std``). Where
the estimate's relative heading of the pair is itself unsure (``unsure_heading``), the whole
image is compared at every shift, and the constraint's standard deviation is that of two places
``max_distance`` apart.

A place pair also says where along the other pass the frame was taken: frame ``i`` resembles
frame ``j`` more than ``j``'s neighbours ``j - 1`` and ``j + 1`` when it was taken abeam of ``j``
(two passes side by side, a mowing row beside the last); the V fit of those three scores places
``i`` between them, ``along`` metres along ``j``'s direction of travel (``along_std``, growing
with the distance between the passes). Across the pass the distance stays free. It is measured
only between passes more than ``along_min_path`` metres of driving apart, which the odometry
cannot keep in register (3 % scale error and noise: over a metre of along-track uncertainty
after 30 m); nearer passes, e.g. the rows of a room, rely on the odometry, as the along-pass
match is biased where walls are near.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .visual import relative_heading
from .warping import PanoramaWarper

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
        along: metres, how far along frame ``j``'s direction of travel frame ``i`` was taken
            (a place pair bracketed by ``j``'s neighbours); else None.
        along_direction: radians, ``j``'s direction of travel in ``j``'s own frame.
        along_std: metres, the standard deviation of ``along``.
    """

    i: int
    j: int
    heading: float
    heading_std: float
    score: float
    kind: str
    position_std: float | None = None
    along: float | None = None
    along_direction: float = 0.0
    along_std: float = 0.0


def candidate_pairs(
    scores: np.ndarray,
    poses: np.ndarray,
    *,
    sequence_window: int,
    max_distance: float,
    place_candidates: int,
    strong_score: float,
    position_std: np.ndarray | None = None,
    gate_sigmas: float = 3.0,
) -> tuple[list[CandidatePair], int]:
    """The pairs worth measuring, and how many candidates the distance gate dropped.

    Args:
        scores: ``(N, N)`` whole-image scores of every frame against every frame.
        poses: ``(N, 3)`` current pose estimate (x, y, heading).
        sequence_window, max_distance, place_candidates, strong_score: see the module text.
        position_std: ``(N,)`` metres, each frame's position uncertainty (None: 0).
        gate_sigmas: standard deviations of the two positions added to a place pair's gate.
    """
    spread = np.zeros(len(poses)) if position_std is None else np.asarray(position_std, dtype=np.float64)
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
                gate = max_distance + gate_sigmas * float(np.hypot(spread[key[0]], spread[key[1]]))
                near = np.hypot(*(positions[key[1]] - positions[key[0]])) <= gate
                if near or score <= strong_score:
                    pairs[key] = CandidatePair(key[0], key[1], "place", score)
                else:
                    dropped += 1
    return sorted(pairs.values(), key=lambda p: (p.i, p.j)), dropped


#: How a pair is measured: the pair, the distance between its places (metres), whether it is
#: strong (one place) or lost (its frames' headings too unsure), the direction from i to j in i's
#: frame and the predicted relative heading (radians; None: no prediction), whether it is warped.
_PairPlan = tuple[CandidatePair, float, bool, bool, float, float | None, bool]


def _plan_pair(
    pair: CandidatePair,
    poses: np.ndarray,
    unsure: np.ndarray,
    strong_score: float,
    unsure_heading: float,
    can_warp: bool,
    min_axis_distance: float,
) -> _PairPlan:
    """How ``pair`` is measured, from the current poses ``(N, 3)`` and heading uncertainties ``(N,)``."""
    i, j = pair.i, pair.j
    dx, dy = poses[j, :2] - poses[i, :2]
    distance = math.hypot(dx, dy)
    strong = pair.kind == "place" and pair.score <= strong_score
    lost = pair.kind == "place" and math.hypot(unsure[i], unsure[j]) > unsure_heading
    line = math.atan2(dy, dx) - poses[i, 2]  # the direction from i to j in i's frame
    prior = None if strong or lost else poses[j, 2] - poses[i, 2]
    # an unsure pair (no prediction to search around) is compared over the whole image: in the
    # first round, before the heading stage has had its say; warped later (the same maps)
    warped = can_warp and not strong and not lost and distance >= min_axis_distance
    return (pair, distance, strong, lost, line, prior, warped)


def _warped_headings(warper: PanoramaWarper | None, plans: list[_PairPlan], direction_range: float) -> dict[int, float]:
    """The relative headings (radians) min-warping measured, by the index of their plan (the
    warped plans whose measurement is finite)."""
    warp_jobs = [k for k, plan in enumerate(plans) if plan[6]]
    if warper is None or not warp_jobs:
        return {}
    results = warper.measure_many(
        np.array([[plans[k][0].i, plans[k][0].j] for k in warp_jobs]),
        np.array([plans[k][4] for k in warp_jobs]),
        direction_range,
        np.array([plans[k][5] for k in warp_jobs]),
        4,
    )
    return {k: result.heading for k, result in zip(warp_jobs, results) if math.isfinite(result.heading)}


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
    max_distance: float,
    scores: np.ndarray | None = None,
    along_std: float = 0.05,
    along_std_per_metre: float = 0.15,
    path_length: np.ndarray | None = None,
    along_min_path: float = 30.0,
    heading_uncertainty: np.ndarray | None = None,
    unsure_heading: float = 0.15,
    min_axis_distance: float = 0.1,
    warper: PanoramaWarper | None = None,
    direction_range: float = math.radians(30.0),
) -> list[VisualConstraint]:
    """Measures the relative heading of every pair (see the module text).

    Args:
        images: ``(N, H, W)`` prepared panoramas.
        pairs: from :func:`candidate_pairs`.
        poses: ``(N, 3)`` current estimate: the distance and the axis between the two places.
        max_distance: metres, the distance gate (the spread of an unsure pair's heading).
        scores: ``(N, N)`` whole-image scores (for the along-pass position); None: none measured.
        along_std, along_std_per_metre: the along-pass position's standard deviation, metres,
            ``along_std + along_std_per_metre * distance`` between the passes.
        path_length: ``(N,)`` metres driven up to each frame (None: no along-pass position).
        along_min_path: metres of driving between two passes for an along-pass position.
        heading_uncertainty: ``(N,)`` radians, each frame's heading uncertainty (None: 0).
        unsure_heading: radians; a pair whose relative heading is less sure than this is
            measured over the whole image.
        min_axis_distance: metres; closer places are compared over every column.
        warper: measures pairs apart (not unsure) by min-warping (:mod:`~nightloc.mapping.warping`)
            instead of the columns along the line between them; None: those columns.
        direction_range: radians; directions of travel tried either side of the estimate's.
    """
    unsure = np.zeros(len(poses)) if heading_uncertainty is None else np.asarray(heading_uncertainty, np.float64)
    plans = [
        _plan_pair(pair, poses, unsure, strong_score, unsure_heading, warper is not None, min_axis_distance)
        for pair in pairs
    ]
    measured = _warped_headings(warper, plans, direction_range)
    out = []
    for k, (pair, distance, strong, lost, line, prior, _) in enumerate(plans):
        i, j = pair.i, pair.j
        if k in measured:
            heading, score = measured[k], float(pair.score)
        else:
            axis = None if distance < min_axis_distance or strong or lost else line
            heading, score = relative_heading(images[j], images[i], axis, axis_half_width, prior=prior)
        spread = 0.0 if strong else max_distance if lost else distance  # a strong pair's places coincide
        along = None
        far = path_length is not None and abs(float(path_length[j] - path_length[i])) >= along_min_path
        if pair.kind == "place" and not strong and scores is not None and far:
            along = _along_pass(scores, poses, i, j)
        out.append(
            VisualConstraint(
                i,
                j,
                heading,
                heading_std + heading_std_per_metre * spread,
                score,
                pair.kind,
                place_position_std if strong else None,
                None if along is None else along[0],
                0.0 if along is None else along[1],
                along_std + along_std_per_metre * (max_distance if lost else distance),
            )
        )
    return out


def _along_pass(scores: np.ndarray, poses: np.ndarray, i: int, j: int) -> tuple[float, float] | None:
    """``(along, direction)`` of frame ``i`` on frame ``j``'s pass (see the module text), or None
    when ``j``'s neighbours do not bracket the best match or ``j`` is the drive's first or last."""
    if j < 1 or j + 1 >= len(poses) or abs(i - j) <= 1:
        return None
    left, centre, right = (float(scores[i, k]) for k in (j - 1, j, j + 1))
    if not centre < min(left, right):
        return None
    delta = 0.5 * (left - right) / max(left - centre, right - centre)  # in frames, |delta| <= 0.5
    step = poses[j + 1, :2] - poses[j, :2] if delta > 0 else poses[j, :2] - poses[j - 1, :2]
    travel = poses[j + 1, :2] - poses[j - 1, :2]
    if not np.hypot(*travel) > 0:
        return None
    direction = math.atan2(travel[1], travel[0]) - poses[j, 2]
    return abs(delta) * float(np.hypot(*step)) * (1.0 if delta > 0 else -1.0), direction
