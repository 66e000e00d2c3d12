"""Rigid 2D fit and ATE against known transforms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nightloc.mapping import RigidTransform2D, absolute_trajectory_error, rigid_fit


def test_rigid_fit_recovers_a_known_transform():
    rng = np.random.default_rng(3)
    source = rng.uniform(-5, 5, (30, 2))
    truth = RigidTransform2D(2.4, (1.5, -3.0))
    fit = rigid_fit(source, truth.apply(source))
    assert math.isclose(fit.rotation, 2.4, abs_tol=1e-12)
    np.testing.assert_allclose(fit.translation, (1.5, -3.0), atol=1e-12)
    assert absolute_trajectory_error(source, truth.apply(source)) == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(fit.inverse().apply(fit.apply(source)), source, atol=1e-12)
    assert fit.apply_headings(np.array([math.pi]))[0] == pytest.approx(2.4 - math.pi)


def test_ate_is_the_rmse_after_the_fit():
    # a square whose corners are pushed out by 0.1 m each: no rotation or shift helps
    square = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    pushed = square * (1 + 0.1 / math.sqrt(2))
    moved = RigidTransform2D(0.7, (4.0, 2.0)).apply(pushed)
    assert absolute_trajectory_error(moved, square) == pytest.approx(0.1, abs=1e-12)


@pytest.mark.parametrize(
    ("a", "b", "text"),
    [(np.zeros((3, 2)), np.zeros((4, 2)), "same shape"), (np.zeros((1, 2)), np.zeros((1, 2)), "at least 2")],
)
def test_bad_positions(a, b, text):
    with pytest.raises(ValueError, match=text):
        rigid_fit(a, b)
    with pytest.raises(ValueError, match="NaN"):
        absolute_trajectory_error(np.full((3, 2), np.nan), np.zeros((3, 2)))
