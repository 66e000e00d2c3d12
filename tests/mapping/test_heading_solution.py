"""The linear heading stage against hand solutions: the odometry's turn bias as a variable, and
visual headings unwrapped in stages of separation along the drive."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nightloc.mapping.candidates import VisualConstraint
from nightloc.mapping.optimiser import solve_heading_graph, solve_headings


def _sequence(n: int, heading: float = 0.0, std: float = 0.01) -> list[VisualConstraint]:
    return [VisualConstraint(k, k + 1, heading, std, 5.0, "sequence") for k in range(n - 1)]


def test_turn_bias_of_a_straight_drive_by_hand():
    """A straight drive whose every measured turn reads ``b``; the images see no turn between
    consecutive frames. With d_k the solved turns and B the bias, least squares over
    n w_o (d + B - b)^2 + n w_v d^2 + w_b B^2 (all d_k equal by symmetry) gives
    B = b / (1 + w_b / (n w_v) + w_b / (n w_o)) and d = w_b B / (n w_v)."""
    n, b = 40, 0.03
    turn_std, visual_std, bias_std = 0.05, 0.01, 0.01
    turns = np.full(n - 1, b)
    solution = solve_heading_graph(
        turns, np.full(n - 1, turn_std), _sequence(n, std=visual_std), np.cumsum([0.0, *turns]), 1e6,
        turn_bias_std=bias_std,
    )  # fmt: skip
    w_o, w_v, w_b, steps = turn_std**-2, visual_std**-2, bias_std**-2, n - 1
    bias = b / (1 + w_b / (steps * w_v) + w_b / (steps * w_o))
    assert solution.turn_bias == pytest.approx(bias, rel=1e-6)
    np.testing.assert_allclose(np.diff(solution.headings), w_b * bias / (steps * w_v), rtol=1e-6)
    # without the bias variable the same turns bend the drive by the weighted mean of the two
    plain = solve_headings(turns, np.full(n - 1, turn_std), _sequence(n, std=visual_std), np.zeros(n), 1e6)
    np.testing.assert_allclose(np.diff(plain), b * w_o / (w_o + w_v), rtol=1e-6)


def test_recovered_bias_straightens_a_long_drive():
    """Noisy turns plus a bias, exact visual headings between consecutive frames: the bias
    estimate is the bias plus the mean of the turn noise (all the data can tell), and with it
    the headings follow the images, where the dead reckoning is off by 2.5 rad."""
    rng = np.random.default_rng(3)
    n, b = 300, -0.012
    truth = np.cumsum(np.concatenate([[0.0], rng.normal(0.0, 0.3, n - 1)]))
    noise = rng.normal(0.0, 0.05, n - 1)
    turns = np.diff(truth) + b + noise
    seen = [VisualConstraint(k, k + 1, truth[k + 1] - truth[k], 0.01, 5.0, "sequence") for k in range(n - 1)]
    reckoned = np.cumsum([0.0, *turns])
    solution = solve_heading_graph(turns, np.full(n - 1, 0.05), seen, reckoned, 3.0, turn_bias_std=0.01)
    assert solution.turn_bias == pytest.approx(b + noise.mean(), abs=0.001)
    assert np.max(np.abs(solution.headings - truth)) < 0.05
    assert np.max(np.abs(reckoned - truth)) > 2.0


def _out_and_back(bias: float) -> tuple[np.ndarray, np.ndarray, list[VisualConstraint], np.ndarray]:
    """20 steps east, a U-turn in two steps, 20 steps west; every turn reads ``bias`` too much.
    The images: each frame against the next (exact), and the last frame against the first
    (the same place, facing the other way: pi)."""
    true_turns = np.array([0.0] * 20 + [math.pi / 2, math.pi / 2] + [0.0] * 20)
    truth = np.concatenate([[0.0], np.cumsum(true_turns)])
    n = len(truth)
    seen = [VisualConstraint(k, k + 1, true_turns[k], 0.01, 5.0, "sequence") for k in range(n - 1)]
    seen.append(VisualConstraint(0, n - 1, math.pi, 0.01, 5.0, "place"))
    separation = np.array([c.j - c.i for c in seen], dtype=np.float64)  # steps apart
    return true_turns + bias, truth, seen, separation


def test_revisit_unwrapped_after_nearer_constraints():
    """Dead reckoning puts the last frame 0.1 * 42 = 4.2 rad past the truth (pi + 4.2 = 7.3):
    the revisit's pi unwraps to 3 pi from there, a full turn wrong. Unwrapped after the
    sequence pairs (first stage: 10 steps) have taken the bias out, it is right."""
    turns, truth, seen, separation = _out_and_back(0.1)
    reckoned = np.concatenate([[0.0], np.cumsum(turns)])
    std = np.full(len(turns), 0.05)
    staged = solve_heading_graph(
        turns, std, seen, reckoned, 1.0, turn_bias_std=0.1, separation=separation, first_stage=10.0
    )
    np.testing.assert_allclose(staged.headings, truth, atol=0.02)
    assert staged.turn_bias == pytest.approx(0.1, abs=0.005)
    at_once = solve_heading_graph(turns, std, seen, reckoned, 1.0, turn_bias_std=0.1)
    assert abs(at_once.headings[-1] - truth[-1]) > 1.0


def test_no_constraints_is_the_dead_reckoning():
    turns = np.array([0.1, -0.2, 0.3])
    solution = solve_heading_graph(turns, np.full(3, 0.05), [], np.zeros(4), 1.0, turn_bias_std=0.01)
    np.testing.assert_allclose(solution.headings, [0.0, 0.1, -0.1, 0.2])
    assert solution.turn_bias == 0.0
