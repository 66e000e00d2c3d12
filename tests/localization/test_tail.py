"""The tail metrics every error reporter uses, against values worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nightloc.localization.tail import longest_run, tail_metrics


def test_one_run_against_hand_computed_values():
    # 12 frames; counted from the 10th: 0.3, 2.0, 1.5 (frames 10-12)
    errors = np.array([9.0, 9.0, 9.0, 0.1, 0.1, 0.1, 0.1, 0.1, 9.0, 0.3, 2.0, 1.5])
    tail = tail_metrics(errors)
    assert tail.n == 3
    assert tail.median_m == pytest.approx(1.5)
    # sorted 0.3, 1.5, 2.0: position 0.95 * 2 = 1.9 -> 1.5 + 0.9 * (2.0 - 1.5) = 1.95
    assert tail.p95_m == pytest.approx(1.95)
    assert tail.share_over_1m == pytest.approx(2 / 3)
    assert tail.longest_run_over_1m == 2  # frame 9's 9 m is before the 10th: not counted


def test_every_frame_and_several_runs():
    a = np.array([0.5, 1.2, 1.3, 0.2, 1.01, 1.02, 1.03, 0.0])  # runs over 1 m: 2, then 3
    b = np.array([2.0, 2.0, 0.1, 0.1])  # a run of 2 (not joined to a's last frames)
    tail = tail_metrics([a, b], first_frame=1)
    assert tail.n == 12
    # pooled sorted: 0.0 0.1 0.1 0.2 0.5 1.01 1.02 1.03 1.2 1.3 2.0 2.0
    assert tail.median_m == pytest.approx((1.01 + 1.02) / 2)
    # position 0.95 * 11 = 10.45 -> 2.0 (both neighbours are 2.0)
    assert tail.p95_m == pytest.approx(2.0)
    assert tail.share_over_1m == pytest.approx(7 / 12)
    assert tail.longest_run_over_1m == 3
    # exactly 1 m is not over
    assert tail_metrics(np.array([1.0, 1.0]), first_frame=1).share_over_1m == 0.0


def test_runs_shorter_than_the_first_frame_count_nothing():
    tail = tail_metrics(np.ones(5) * 3.0)
    assert tail.n == 0 and math.isnan(tail.median_m) and math.isnan(tail.p95_m) and tail.longest_run_over_1m == 0


def test_longest_run_edges():
    assert longest_run(np.array([], dtype=bool)) == 0
    assert longest_run(np.array([True] * 4)) == 4
    assert longest_run(np.array([True, False, True, True, False])) == 2


@pytest.mark.parametrize(("kwargs", "words"), [({"first_frame": 0}, "first_frame"), ({"threshold": -1.0}, "threshold")])
def test_bad_arguments_are_named(kwargs, words):
    with pytest.raises(ValueError, match=words):
        tail_metrics(np.zeros(3), **kwargs)
    with pytest.raises(ValueError, match="1-D"):
        tail_metrics([np.zeros((2, 2))])
