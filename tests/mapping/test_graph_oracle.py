"""The pose graph against hand-solvable drives: a square with one closure."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("gtsam")

from nightloc.mapping.candidates import VisualConstraint
from nightloc.mapping.dead_reckoning import compose_steps, dead_reckoning
from nightloc.mapping.optimiser import optimise_graph, solve_headings, solve_positions
from nightloc.motion.wheel_noise import WheelNoise

#: Isotropic 1 cm per step, nearly exact turns: every step weighs the same in every direction.
ISOTROPIC = WheelNoise(
    scale_std=0.0, distance_std=0.0, turn_std=1e-6, turn_bias_std=0.0, min_distance_std=0.01, min_turn_std=1e-6
)
SQUARE_STEPS = np.array([(1.0, 0.0, math.pi / 2)] * 3 + [(1.2, 0.0, math.pi / 2)])  # the last side overshoots


def _closure(position_std=1e-3):
    # frame 4 is back at frame 0, heading turned a full circle (measured as 0 by the images)
    return [VisualConstraint(0, 4, 0.0, 1e-4, 5.0, "place", position_std)]


def test_dead_reckoning_of_the_square():
    poses, cov = dead_reckoning(SQUARE_STEPS, ISOTROPIC)
    np.testing.assert_allclose(poses[:, :2], [[0, 0], [1, 0], [1, 1], [0, 1], [0, -0.2]], atol=1e-12)
    assert cov[0].max() == 0 and np.all(np.diff(cov[:, 0, 0] + cov[:, 1, 1]) > 0)  # grows along the drive


def test_square_with_one_closure_spreads_the_error_evenly():
    """Hand solution: the 0.2 m the last side overshoots is taken back in equal quarters, each
    step's correction along +y: p_k = dead_reckoning_k + (k / 4) * (0, 0.2)."""
    steps = SQUARE_STEPS
    cov = ISOTROPIC.step_covariances(steps[:, 0], steps[:, 1])
    reckoned = compose_steps(steps)
    # started as the teach run starts it: headings, then positions (linear), then the whole graph;
    # from the dead reckoning itself the closure, 200 standard deviations off, would be taken
    # for a false match by the robust kernel
    headings = solve_headings(steps[:, 2], np.sqrt(cov[:, 2, 2]), _closure(), reckoned[:, 2], 1.0)
    initial = np.column_stack([solve_positions(headings, steps, cov, _closure(), 1.0), headings])
    solution = optimise_graph(initial, steps, cov, _closure(), robust_scale=1.0)
    expected = reckoned[:, :2] + np.arange(5)[:, None] / 4 * np.array([0.0, 0.2])
    np.testing.assert_allclose(solution.poses[:, :2], expected, atol=2e-3)
    np.testing.assert_allclose(solution.poses[:, 2], [0, math.pi / 2, math.pi, -math.pi / 2, 0], atol=1e-4)
    # marginals: frame 0 is the fixed origin; the mid-drive frame is the least sure
    spread = solution.covariances[:, 0, 0] + solution.covariances[:, 1, 1]
    assert spread[0] < 1e-9 and spread[2] == spread.max()
    assert solution.residuals[0] < 3.0  # the closure is accepted


def test_linear_initialisation_matches_the_hand_solution():
    steps = SQUARE_STEPS
    cov = ISOTROPIC.step_covariances(steps[:, 0], steps[:, 1])
    headings = solve_headings(steps[:, 2], np.sqrt(cov[:, 2, 2]), _closure(), compose_steps(steps)[:, 2], 1.0)
    np.testing.assert_allclose(headings, np.arange(5) * math.pi / 2, atol=1e-6)  # unwrapped
    positions = solve_positions(headings, steps, cov, _closure(), 1.0)
    expected = compose_steps(steps)[:, :2] + np.arange(5)[:, None] / 4 * np.array([0.0, 0.2])
    np.testing.assert_allclose(positions, expected, atol=2e-3)


def test_heading_closure_removes_a_turn_bias():
    """Every turn over-reads by 0.02 rad; the images say frame 4 faces as frame 0 did: the
    heading solution takes 0.02 rad back from each turn (equal weights), as by hand."""
    steps = np.array([(1.0, 0.0, math.pi / 2 + 0.02)] * 4)
    turn_std = np.full(4, 0.05)
    closure = [VisualConstraint(0, 4, 0.0, 1e-4, 5.0, "place")]
    headings = solve_headings(steps[:, 2], turn_std, closure, compose_steps(steps)[:, 2], 1.0)
    np.testing.assert_allclose(headings, np.arange(5) * math.pi / 2, atol=1e-6)


def test_closed_loop_factor_ties_the_ends():
    steps = SQUARE_STEPS
    cov = ISOTROPIC.step_covariances(steps[:, 0], steps[:, 1])
    exact_headings = [VisualConstraint(k, k + 1, math.pi / 2, 1e-4, 5.0, "sequence") for k in range(4)]
    solution = optimise_graph(compose_steps(steps), steps, cov, exact_headings, robust_scale=1.0, closed_loop_std=1e-3)
    np.testing.assert_allclose(solution.poses[4, :2], [0.0, 0.0], atol=2e-3)
    np.testing.assert_allclose(solution.poses[2, :2], [1.0, 1.1], atol=2e-3)


def test_interpolated_marginals_follow_the_map_frame():
    """10 m east with a poor odometer (the uncertainty a long ellipse along x), then a spin on the
    spot, 45 degrees a step; no visual constraint. Computed every other frame and interpolated,
    the spinning frames keep the ellipse (to 2 %): interpolation happens in the map frame, where
    the spin changes nothing, not in the body frame, which turns 90 degrees between two sampled
    frames (the first pass's intermediate rounds gated with those: the ellipse comes out round,
    its long axis 28 % short)."""
    noise = WheelNoise(scale_std=0.0, distance_std=0.1, turn_std=0.002, turn_bias_std=0.0)
    steps = np.array([(1.0, 0.0, 0.0)] * 10 + [(0.0, 0.0, math.pi / 4)] * 8)
    cov = noise.step_covariances(steps[:, 0], steps[:, 1])
    poses, _ = dead_reckoning(steps, noise)
    exact = optimise_graph(poses, steps, cov, [], robust_scale=1.0)
    sampled = optimise_graph(poses, steps, cov, [], robust_scale=1.0, marginal_stride=2)
    long_axis = np.sqrt(np.linalg.eigvalsh(exact.covariances[10:, :2, :2])[:, -1])
    assert long_axis.min() > 0.3 and np.ptp(long_axis) < 0.01  # the spin keeps a 0.3 m ellipse
    between = np.sqrt(np.linalg.eigvalsh(sampled.covariances[10:, :2, :2])[:, -1])
    np.testing.assert_allclose(between, long_axis, rtol=0.02)
