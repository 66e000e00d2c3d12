"""Route evaluation: ground truth, precision-recall, recall at 100 % precision and best F1,
checked against brute force over every threshold."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nightloc import route
from nightloc.route import GroundTruth


def brute_force_curve(scores, correct, positives):
    rows = []
    for t in np.unique(scores[~np.isnan(scores)]):
        accepted = ~np.isnan(scores) & (scores <= t)
        tp = int((accepted & correct).sum())
        rows.append((t, tp / accepted.sum(), tp / positives))
    return np.array(rows)


def test_precision_recall_matches_brute_force():
    rng = np.random.default_rng(0)
    scores = np.round(rng.random(300), 2)  # many ties
    scores[rng.random(300) < 0.1] = np.nan
    correct = rng.random(300) < 0.6
    curve = route.precision_recall(scores, correct, 250)
    expected = brute_force_curve(scores, correct, 250)
    np.testing.assert_allclose(curve.thresholds, expected[:, 0])
    np.testing.assert_allclose(curve.precision, expected[:, 1])
    np.testing.assert_allclose(curve.recall, expected[:, 2])
    perfect = expected[expected[:, 1] == 1.0]
    assert curve.recall_at_precision(1.0) == (perfect[:, 2].max() if len(perfect) else 0.0)
    f1 = 2 * expected[:, 1] * expected[:, 2] / (expected[:, 1] + expected[:, 2])
    best = curve.best_f1()
    assert best[0] == pytest.approx(f1.max())
    assert best[3] == expected[np.argmax(f1), 0]


def test_hand_computed_example():
    # Scores (lower = better) and correctness; 5 positives.
    scores = np.array([0.1, 0.2, 0.3, 0.4, np.nan, 0.5])
    correct = np.array([True, True, False, True, False, True])
    curve = route.precision_recall(scores, correct, 5)
    np.testing.assert_allclose(curve.precision, [1, 1, 2 / 3, 3 / 4, 4 / 5])
    np.testing.assert_allclose(curve.recall, [0.2, 0.4, 0.4, 0.6, 0.8])
    assert curve.recall_at_precision(1.0) == 0.4
    assert curve.threshold_at_precision(1.0) == 0.2
    assert curve.best_f1()[0] == pytest.approx(0.8)


def test_ground_truth_from_frames():
    truth = GroundTruth.from_frames(6, 5, tolerance=1, correspondence=np.array([0, 1, 2, 4, 7, -1]))
    refs = np.array([1, -1, 4, 3, 4, 0])
    np.testing.assert_array_equal(truth.correct(refs), [True, False, False, True, False, False])
    np.testing.assert_array_equal(truth.positives(), [True, True, True, True, False, False])
    identity = GroundTruth.from_frames(4, 4, 0)
    np.testing.assert_array_equal(identity.correct(np.array([0, 2, 2, -1])), [True, False, True, False])
    with pytest.raises(ValueError, match="refs must lie"):
        identity.correct(np.array([0, 1, 2, 9]))
    with pytest.raises(ValueError, match="tolerance"):
        GroundTruth.from_frames(4, 4, -1)
    with pytest.raises(ValueError, match="correspondence"):
        GroundTruth.from_frames(4, 4, 1, correspondence=np.zeros(3, int))


def test_ground_truth_from_positions_matches_brute_force():
    rng = np.random.default_rng(1)
    refs = np.cumsum(rng.uniform(0.5, 1.5, size=(80, 2)), axis=0)
    queries = refs[::2] + rng.normal(0, 1.0, size=(40, 2))
    queries[5] += [50.0, -50.0]  # far from every reference: not a positive
    truth = GroundTruth.from_positions(queries, refs, 3.0)
    matched = rng.integers(-1, 80, size=40)
    distance = np.linalg.norm(refs[None] - queries[:, None], axis=2)
    expected = np.array([m >= 0 and distance[q, m] <= 3.0 for q, m in enumerate(matched)])
    np.testing.assert_array_equal(truth.correct(matched), expected)
    np.testing.assert_array_equal(truth.positives(), distance.min(axis=1) <= 3.0)
    assert not truth.positives()[5]
    nearest = truth.true_refs()
    assert nearest[5] == -1 and nearest[0] == np.argmin(distance[0])
    with pytest.raises(ValueError, match="NaN"):
        GroundTruth.from_positions(np.full((3, 2), np.nan), refs, 3.0)
    with pytest.raises(ValueError, match="tolerance"):
        GroundTruth.from_positions(queries, refs, 0.0)


def test_evaluate_matches_ignores_undefined_and_counts_every_positive():
    refs = np.array([-1, 1, 2, 0, -1])
    scores = np.array([np.nan, 0.5, 0.7, 0.9, np.nan])
    evaluation = route.evaluate_matches(refs, scores, GroundTruth.from_frames(5, 5, 0))
    assert evaluation.recall_at_100 == pytest.approx(2 / 5)  # every query is a positive
    assert evaluation.threshold_at_100 == 0.7
    assert "recall at 100% precision 0.400" in evaluation.summary()
    empty = route.evaluate_matches(np.full(3, -1), np.full(3, np.nan), GroundTruth.from_frames(3, 3, 0))
    assert empty.recall_at_100 == 0.0 and empty.best_f1 == 0.0 and empty.threshold_at_100 == -math.inf
