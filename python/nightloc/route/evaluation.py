"""Evaluation of route matches: ground truth, precision-recall, recall at 100 % precision, F1.

Ground truth comes from frame correspondence (query q shows the place of reference
``correspondence[q]``, by default q itself; a match is correct within ``tolerance`` frames) or from
positions (a match is correct when the matched reference lies within ``tolerance`` metres of the
query's position). A query is a *positive* when some reference is correct for it.

A match is *accepted* at threshold t when it is defined and ``score <= t`` (lower scores are more
confident, as in OpenSeqSLAM). Over all thresholds (every distinct score):

* precision = correct accepted / accepted,
* recall = correct accepted / positives (every positive query counts, including those whose
  match is undefined at the ends of the route),

which is how the OpenSeqSLAM reference figures are computed (0.402 recall at 100 % precision on
the golden subset A).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._validate import coordinates, metres

__all__ = [
    "GroundTruth",
    "PRCurve",
    "RouteEvaluation",
    "evaluate_matches",
    "precision_recall",
]


@dataclass(frozen=True)
class GroundTruth:
    """Which reference matches are correct for each query.

    Build one with :meth:`from_frames` or :meth:`from_positions`.

    Attributes:
        kind: ``"frames"`` or ``"positions"``.
        tolerance: frames (``"frames"``) or metres (``"positions"``).
        n_queries, n_refs: sizes of the two traverses.
        correspondence: ``(n_query,)`` int64 true reference per query (``"frames"``), or None.
        query_positions, ref_positions: ``(n, 2)`` float64 metres (``"positions"``), or None.
    """

    kind: str
    tolerance: float
    n_queries: int
    n_refs: int
    correspondence: np.ndarray | None = None
    query_positions: np.ndarray | None = None
    ref_positions: np.ndarray | None = None

    @classmethod
    def from_frames(
        cls, n_queries: int, n_refs: int, tolerance: int = 2, correspondence: np.ndarray | None = None
    ) -> GroundTruth:
        """Frame-aligned traverses: query q is reference ``correspondence[q]`` (default q).

        A match r is correct when ``|r - correspondence[q]| <= tolerance`` and that reference
        exists. Queries whose correspondence lies outside ``0 .. n_refs-1`` (e.g. a query route
        longer than the reference) have no correct match; ``-1`` marks a query with none.
        """
        for name, value in (("n_queries", n_queries), ("n_refs", n_refs)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be a positive int, got {value!r}")
        if isinstance(tolerance, bool) or not isinstance(tolerance, (int, np.integer)) or tolerance < 0:
            raise ValueError(f"tolerance must be an int >= 0 frames, got {tolerance!r}")
        if correspondence is None:
            truth = np.arange(n_queries, dtype=np.int64)
        else:
            truth = np.asarray(correspondence)
            if truth.shape != (n_queries,) or truth.dtype.kind not in "iu":
                raise ValueError(
                    f"correspondence must be ({n_queries},) integers (reference per query, -1 for none), "
                    f"got shape {truth.shape}, dtype {truth.dtype}"
                )
            truth = truth.astype(np.int64)
        truth = np.where((truth >= 0) & (truth < n_refs), truth, -1)
        truth.setflags(write=False)
        return cls("frames", float(tolerance), int(n_queries), int(n_refs), correspondence=truth)

    @classmethod
    def from_positions(cls, query_positions: np.ndarray, ref_positions: np.ndarray, tolerance: float) -> GroundTruth:
        """Traverses with poses: a match is correct within ``tolerance`` metres.

        Args:
            query_positions: ``(n_query, 2)`` metres.
            ref_positions: ``(n_ref, 2)`` metres.
            tolerance: metres (> 0); the paper's creek experiment used 3 m.
        """
        arrays = []
        for name, value in (("query_positions", query_positions), ("ref_positions", ref_positions)):
            array = np.asarray(value, dtype=np.float64)
            if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] == 0:
                raise ValueError(f"{name} must be a non-empty (n, 2) array of metres, got shape {array.shape}")
            coordinates(array, name)
            array = array.copy()
            array.setflags(write=False)
            arrays.append(array)
        if metres(tolerance, "tolerance", minimum=0.0) <= 0:
            raise ValueError(f"tolerance must be a positive number of metres, got {tolerance!r}")
        return cls(
            "positions",
            float(tolerance),
            arrays[0].shape[0],
            arrays[1].shape[0],
            query_positions=arrays[0],
            ref_positions=arrays[1],
        )

    def _correspondence(self) -> np.ndarray:
        if self.correspondence is None:
            raise ValueError("this ground truth has no frame correspondence")
        return self.correspondence

    def _positions(self) -> tuple[np.ndarray, np.ndarray]:
        """(reference positions, query positions) of a positions ground truth."""
        if self.ref_positions is None or self.query_positions is None:
            raise ValueError("this ground truth has no positions")
        return self.ref_positions, self.query_positions

    def correct(self, refs: np.ndarray) -> np.ndarray:
        """``(n_query,)`` bool: the match ``refs[q]`` (-1 = none) is correct."""
        matched = np.asarray(refs)
        if matched.shape != (self.n_queries,):
            raise ValueError(f"refs must have shape ({self.n_queries},), got {matched.shape}")
        matched = matched.astype(np.int64)
        if (matched >= self.n_refs).any() or (matched < -1).any():
            raise ValueError(f"refs must lie in -1 .. {self.n_refs - 1}")
        defined = matched >= 0
        if self.kind == "frames":
            truth = self._correspondence()
            return defined & (truth >= 0) & (np.abs(matched - truth) <= self.tolerance)
        out = np.zeros(self.n_queries, dtype=bool)
        index = np.flatnonzero(defined)
        refs_xy, queries_xy = self._positions()
        gap = refs_xy[matched[index]] - queries_xy[index]
        out[index] = np.hypot(gap[:, 0], gap[:, 1]) <= self.tolerance
        return out

    def positives(self) -> np.ndarray:
        """``(n_query,)`` bool: some reference is a correct match for the query."""
        if self.kind == "frames":
            # Every reference within the tolerance of an existing correspondence exists.
            return np.asarray(self._correspondence() >= 0)
        refs_xy, queries_xy = self._positions()
        distance, _ = cKDTree(refs_xy).query(queries_xy, k=1)
        return np.asarray(distance <= self.tolerance)

    def true_refs(self) -> np.ndarray:
        """``(n_query,)`` int64 best true reference per query (the correspondence, or the
        nearest reference by position), -1 where none is within the tolerance."""
        if self.kind == "frames":
            return self._correspondence().copy()
        refs_xy, queries_xy = self._positions()
        distance, nearest = cKDTree(refs_xy).query(queries_xy, k=1)
        return np.where(distance <= self.tolerance, nearest, -1).astype(np.int64)


@dataclass(frozen=True)
class PRCurve:
    """Precision and recall at every distinct score threshold (ascending).

    Attributes:
        thresholds: ``(k,)`` float64 scores; at ``thresholds[i]`` the matches with
            ``score <= thresholds[i]`` are accepted.
        precision, recall: ``(k,)`` float64.
        accepted, true_positives: ``(k,)`` int64 counts.
        positives: number of queries with a correct reference.
    """

    thresholds: np.ndarray
    precision: np.ndarray
    recall: np.ndarray
    accepted: np.ndarray
    true_positives: np.ndarray
    positives: int

    def recall_at_precision(self, precision: float = 1.0) -> float:
        """Largest recall among thresholds whose precision is >= ``precision`` (0 if none)."""
        ok = self.precision >= precision - 1e-12
        return float(self.recall[ok].max()) if ok.any() else 0.0

    def threshold_at_precision(self, precision: float = 1.0) -> float:
        """The largest threshold whose precision is >= ``precision`` (-inf if none)."""
        ok = np.flatnonzero(self.precision >= precision - 1e-12)
        return float(self.thresholds[ok[-1]]) if ok.size else -math.inf

    def f1(self) -> np.ndarray:
        """``(k,)`` F1 scores (0 where precision and recall are both 0)."""
        total = self.precision + self.recall
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total > 0, 2 * self.precision * self.recall / total, 0.0)

    def best_f1(self) -> tuple:
        """``(f1, precision, recall, threshold)`` at the threshold with the largest F1 (the lowest
        such threshold on ties); zeros and -inf for an empty curve."""
        if self.thresholds.size == 0:
            return 0.0, 0.0, 0.0, -math.inf
        scores = self.f1()
        i = int(np.argmax(scores))
        return float(scores[i]), float(self.precision[i]), float(self.recall[i]), float(self.thresholds[i])


def precision_recall(scores: np.ndarray, correct: np.ndarray, positives: int) -> PRCurve:
    """The precision-recall curve of matches with ``scores`` (NaN = undefined, never accepted)
    and correctness ``correct``, against ``positives`` queries with a correct reference."""
    score = np.asarray(scores, dtype=np.float64)
    good = np.asarray(correct, dtype=bool)
    if score.shape != good.shape or score.ndim != 1:
        raise ValueError(f"scores and correct must be matching 1-D arrays, got {score.shape} and {good.shape}")
    if isinstance(positives, bool) or not isinstance(positives, (int, np.integer)) or positives < 0:
        raise ValueError(f"positives must be an int >= 0, got {positives!r}")
    defined = ~np.isnan(score)
    order = np.argsort(score[defined], kind="stable")
    sorted_scores = score[defined][order]
    sorted_good = good[defined][order]
    if sorted_scores.size == 0:
        empty = np.zeros(0)
        return PRCurve(empty, empty, empty, np.zeros(0, np.int64), np.zeros(0, np.int64), int(positives))
    cumulative_tp = np.cumsum(sorted_good, dtype=np.int64)
    # Last index of each run of equal scores: all ties are accepted together.
    last = np.flatnonzero(np.append(sorted_scores[1:] != sorted_scores[:-1], True))
    accepted = (last + 1).astype(np.int64)
    tp = cumulative_tp[last]
    precision = tp / accepted
    recall = tp / positives if positives > 0 else np.zeros(len(last))
    return PRCurve(sorted_scores[last], precision, recall.astype(np.float64), accepted, tp, int(positives))


@dataclass(frozen=True)
class RouteEvaluation:
    """Summary of route matches against ground truth.

    Attributes:
        curve: the :class:`PRCurve`.
        correct: ``(n_query,)`` bool, the match is correct (regardless of its score).
        positives: ``(n_query,)`` bool, the query has a correct reference.
        recall_at_100: recall at 100 % precision.
        threshold_at_100: the largest score threshold with 100 % precision (-inf if none).
        best_f1, best_f1_precision, best_f1_recall, best_f1_threshold: the best F1 point.
        true_refs: ``(n_query,)`` int64 true reference per query (:meth:`GroundTruth.true_refs`).
    """

    curve: PRCurve
    correct: np.ndarray
    positives: np.ndarray
    recall_at_100: float
    threshold_at_100: float
    best_f1: float
    best_f1_precision: float
    best_f1_recall: float
    best_f1_threshold: float
    true_refs: np.ndarray

    def summary(self) -> str:
        """One line: recall at 100 % precision and best F1."""
        return (
            f"recall at 100% precision {self.recall_at_100:.3f}; best F1 {self.best_f1:.3f} "
            f"(precision {self.best_f1_precision:.3f}, recall {self.best_f1_recall:.3f}); "
            f"{int(self.correct.sum())} of {int(self.positives.sum())} queries matched correctly at any score"
        )


def evaluate_matches(refs: np.ndarray, scores: np.ndarray, truth: GroundTruth) -> RouteEvaluation:
    """Evaluates matches (``refs`` with -1 undefined, ``scores`` lower = better) against ``truth``."""
    if np.shape(refs) != np.shape(scores):
        raise ValueError(
            f"refs and scores must have one entry per query, got shapes {np.shape(refs)} and {np.shape(scores)}"
        )
    correct = truth.correct(refs)
    positives = truth.positives()
    score = np.asarray(scores, dtype=np.float64)
    score = np.where(np.asarray(refs) >= 0, score, np.nan)
    curve = precision_recall(score, correct, int(positives.sum()))
    f1, precision, recall, threshold = curve.best_f1()
    return RouteEvaluation(
        curve=curve,
        correct=correct,
        positives=positives,
        recall_at_100=curve.recall_at_precision(1.0),
        threshold_at_100=curve.threshold_at_precision(1.0),
        best_f1=f1,
        best_f1_precision=precision,
        best_f1_recall=recall,
        best_f1_threshold=threshold,
        true_refs=truth.true_refs(),
    )
