"""Odometry: Table III noise statistics, robot-frame motion, conversions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nightloc.motion.odometry import (
    NOISE_MODELS,
    WHEEL_ODOMETRY_NOISE,
    MapDisplacement,
    NoiseModel,
    RobotMotion,
    as_motion,
    compose_motions,
    log_noise_model,
    noise_model,
    reverse_motion,
    robot_steps_to_map,
    simulate_map_odometry,
    simulate_robot_odometry,
    true_map_steps,
    true_robot_motions,
    wrap_angle,
)


def _wandering_path(rng, n=200, step=0.4):
    heading = np.cumsum(rng.normal(0, 0.3, n))
    steps = step * np.column_stack([np.cos(heading), np.sin(heading)])
    return np.cumsum(steps, axis=0), wrap_angle(heading + rng.normal(0, 0.2, n))


def test_table_three():
    assert {k: (m.distance_std, m.heading_std) for k, m in NOISE_MODELS.items()} == {
        0: (0.0, 0.0),
        1: (0.1, 0.02),
        2: (0.25, 0.05),
        3: (0.5, 0.1),
    }
    assert noise_model(2) is NOISE_MODELS[2]
    with pytest.raises(ValueError, match="Table III"):
        noise_model(4)
    with pytest.raises(TypeError):
        noise_model("3")


@pytest.mark.parametrize("model", [1, 2, 3])
def test_map_odometry_noise_has_the_table_statistics(model):
    rng = np.random.default_rng(0)
    positions, _ = _wandering_path(rng, n=20001, step=2.0)  # long steps: the direction noise stays small
    truth = true_map_steps(positions)[1:]
    noisy = simulate_map_odometry(positions, model, rng=np.random.default_rng(model))[1:]
    length_error = np.hypot(*noisy.T) - np.hypot(*truth.T)
    angle_error = wrap_angle(np.arctan2(noisy[:, 1], noisy[:, 0]) - np.arctan2(truth[:, 1], truth[:, 0]))
    expected = NOISE_MODELS[model]
    n = len(truth)
    assert abs(length_error.mean()) < 4 * expected.distance_std / math.sqrt(n)
    assert length_error.std() == pytest.approx(expected.distance_std, rel=0.03)
    assert abs(angle_error.mean()) < 4 * expected.heading_std / math.sqrt(n)
    assert angle_error.std() == pytest.approx(expected.heading_std, rel=0.03)
    # independent per step
    assert abs(np.corrcoef(length_error[:-1], length_error[1:])[0, 1]) < 0.03


def test_model_zero_is_exact_and_seeds_repeat():
    rng = np.random.default_rng(1)
    positions, _ = _wandering_path(rng, 50)
    np.testing.assert_array_equal(simulate_map_odometry(positions, 0, 5), true_map_steps(positions))
    a = simulate_map_odometry(positions, 3, 7)
    np.testing.assert_array_equal(a, simulate_map_odometry(positions, 3, np.random.default_rng(7)))
    assert not np.array_equal(a, simulate_map_odometry(positions, 3, 8))
    assert np.all(a[0] == 0)


def test_true_robot_motions_round_trip_to_map_steps():
    rng = np.random.default_rng(2)
    positions, headings = _wandering_path(rng, 60)
    motions = true_robot_motions(positions, headings)
    assert motions[0] == RobotMotion(0.0, 0.0, 0.0)
    steps = robot_steps_to_map(motions[1:], headings[-1])
    np.testing.assert_allclose(steps, np.diff(positions, axis=0), atol=1e-9)
    # a robot heading north that drives 1 m forward and turns left by 90 degrees
    motion = true_robot_motions(np.array([[0.0, 0.0], [0.0, 1.0]]), np.array([np.pi / 2, np.pi]))[1]
    assert (motion.forward, motion.left, motion.turn) == pytest.approx((1.0, 0.0, np.pi / 2))


def test_reversed_motions_drive_the_path_backwards():
    rng = np.random.default_rng(3)
    positions, headings = _wandering_path(rng, 40)
    motions = true_robot_motions(positions, headings)
    back = true_robot_motions(positions[::-1], headings[::-1])  # the same path driven backwards
    for k in range(1, len(motions)):
        r = reverse_motion(motions[k])
        assert (r.forward, r.left, r.turn) == pytest.approx(
            (back[len(motions) - k].forward, back[len(motions) - k].left, back[len(motions) - k].turn), abs=1e-9
        )
        there_and_back = compose_motions([motions[k], r])
        assert (there_and_back.forward, there_and_back.left) == pytest.approx((0.0, 0.0), abs=1e-12)
        assert there_and_back.turn == pytest.approx(0.0, abs=1e-12)
    assert reverse_motion(MapDisplacement(1.5, -2.0)) == MapDisplacement(-1.5, 2.0)
    assert reverse_motion(None) is None


def test_mixed_motions_and_missing_heading():
    steps = robot_steps_to_map([MapDisplacement(1.0, 2.0), RobotMotion(1.0, 0.0, np.pi / 2)], heading_now=np.pi / 2)
    np.testing.assert_allclose(steps, [[1.0, 2.0], [1.0, 0.0]], atol=1e-12)  # heading 0 before the turn
    np.testing.assert_allclose(robot_steps_to_map([MapDisplacement(1.0, 2.0)], None), [[1.0, 2.0]])
    with pytest.raises(ValueError, match="heading"):
        robot_steps_to_map([RobotMotion(1.0)], math.nan)


def test_robot_odometry_noise_statistics():
    rng = np.random.default_rng(3)
    positions, headings = _wandering_path(rng, 20001)
    truth = true_robot_motions(positions, headings)[1:]
    noisy = simulate_robot_odometry(positions, headings, 2, rng=11)[1:]
    true_vectors = np.array([(m.forward, m.left) for m in truth])
    noisy_vectors = np.array([(m.forward, m.left) for m in noisy])
    true_length = np.hypot(*true_vectors.T)
    unit = true_vectors / true_length[:, None]
    # the translation keeps its direction in the robot frame; its signed length gets the noise
    cross = unit[:, 0] * noisy_vectors[:, 1] - unit[:, 1] * noisy_vectors[:, 0]
    np.testing.assert_allclose(cross, 0.0, atol=1e-9)
    length_error = (noisy_vectors * unit).sum(axis=1) - true_length
    turn_error = np.array([m.turn for m in noisy]) - np.array([m.turn for m in truth])
    assert length_error.std() == pytest.approx(0.25, rel=0.03)
    assert abs(length_error.mean()) < 4 * 0.25 / math.sqrt(len(truth))
    assert turn_error.std() == pytest.approx(0.05, rel=0.03)
    assert abs(turn_error.mean()) < 4 * 0.05 / math.sqrt(len(truth))


def test_as_motion_accepts_pairs_and_rejects_the_rest():
    assert as_motion((0.5, -1)) == MapDisplacement(0.5, -1.0)
    assert as_motion(np.array([1.0, 2.0])) == MapDisplacement(1.0, 2.0)
    assert as_motion(None) is None
    motion = RobotMotion(0.3, turn=0.1)
    assert as_motion(motion) is motion
    with pytest.raises(ValueError, match="RobotMotion"):
        as_motion((1.0, 2.0, 3.0))
    with pytest.raises(TypeError):
        as_motion("1,2")
    with pytest.raises(ValueError, match="finite"):
        as_motion((np.nan, 0.0))
    with pytest.raises(TypeError):
        RobotMotion("fast")


def test_wrap_angle():
    np.testing.assert_allclose(
        wrap_angle(np.array([0.0, np.pi, -np.pi, 3 * np.pi / 2, -3 * np.pi / 2, 7.0])),
        [0.0, np.pi, np.pi, -np.pi / 2, np.pi / 2, 7.0 - 2 * np.pi],
    )
    assert isinstance(wrap_angle(1.0), float)


def test_custom_noise_model():
    positions = np.column_stack([np.arange(1000.0), np.zeros(1000)])
    steps = simulate_map_odometry(positions, NoiseModel(0.0, 0.2), 1)[1:]
    assert np.hypot(*steps.T) == pytest.approx(np.ones(999))
    with pytest.raises(ValueError, match="distance_std"):
        simulate_map_odometry(positions, NoiseModel(-1.0, 0.0))


def test_step_scaled_noise_is_checked_and_not_simulated():
    positions = np.column_stack([np.arange(10.0), np.zeros(10)])
    with pytest.raises(ValueError, match="heading_per_radian"):
        noise_model(NoiseModel(0.1, 0.02, 0.05, -0.1))
    with pytest.raises(ValueError, match="distance_per_metre"):
        noise_model(NoiseModel(0.1, 0.02, math.nan))
    # the simulators draw Table III terms only: a step-scaled model is refused, not half-drawn
    with pytest.raises(ValueError, match="Table III"):
        simulate_map_odometry(positions, NoiseModel(0.1, 0.02, 0.05))
    with pytest.raises(ValueError, match="Table III"):
        simulate_robot_odometry(positions, np.zeros(10), WHEEL_ODOMETRY_NOISE)


def test_a_log_of_wheel_odometry_gets_the_step_scaled_model():
    assert log_noise_model([None, RobotMotion(0.5, 0.0, 0.1)]) == WHEEL_ODOMETRY_NOISE
    assert log_noise_model([None, MapDisplacement(0.5, 0.0)]) == 1
    assert log_noise_model([None, None]) == 1
    assert WHEEL_ODOMETRY_NOISE.step_scaled and not NoiseModel(0.1, 0.02).step_scaled
