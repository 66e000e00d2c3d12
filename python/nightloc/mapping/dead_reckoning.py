"""Dead reckoning: wheel odometry chained into poses, with its covariance.

The teach run starts from here: pose 0 is the origin of the map frame (heading 0) and each
step ``(forward, left, turn)`` (robot frame at the step's start) moves the robot on. The
covariance is propagated with the step's Jacobians (first order), each step's own covariance
from a :class:`~nightloc.motion.wheel_noise.WheelNoise` model.
"""

from __future__ import annotations

import math

import numpy as np

from ..motion.wheel_noise import WheelNoise

__all__ = ["compose_steps", "dead_reckoning"]


def compose_steps(steps: np.ndarray, start: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """``(N + 1, 3)`` poses ``(x, y, heading)`` from ``(N, 3)`` robot-frame steps ``(forward, left,
    turn)``, starting at ``start``; headings unwrapped (they accumulate the turns)."""
    moves = np.asarray(steps, dtype=np.float64).reshape(-1, 3)
    poses = np.empty((len(moves) + 1, 3))
    poses[0] = start
    x, y, h = (float(v) for v in start)
    for k, (forward, left, turn) in enumerate(moves):
        c, s = math.cos(h), math.sin(h)
        x += c * forward - s * left
        y += s * forward + c * left
        h += turn
        poses[k + 1] = (x, y, h)
    return poses


def dead_reckoning(steps: np.ndarray, noise: WheelNoise | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Poses and their covariances from chained wheel odometry.

    Args:
        steps: ``(N - 1, 3)`` robot-frame steps between consecutive frames.
        noise: the wheel-noise model of each step's covariance (default :class:`WheelNoise`).

    Returns:
        ``(poses, covariances)``: ``(N, 3)`` poses (x, y metres; heading radians, unwrapped) with
        pose 0 at the origin, and ``(N, 3, 3)`` covariances (pose 0's is zero).
    """
    noise = noise or WheelNoise()
    moves = np.asarray(steps, dtype=np.float64).reshape(-1, 3)
    poses = compose_steps(moves)
    step_cov = noise.step_covariances(moves[:, 0], moves[:, 1]) if len(moves) else np.zeros((0, 3, 3))
    cov = np.zeros((len(poses), 3, 3))
    for k, (forward, left, _) in enumerate(moves):
        h = poses[k, 2]
        c, s = math.cos(h), math.sin(h)
        jac_pose = np.array([[1.0, 0.0, -s * forward - c * left], [0.0, 1.0, c * forward - s * left], [0, 0, 1.0]])
        jac_step = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        cov[k + 1] = jac_pose @ cov[k] @ jac_pose.T + jac_step @ step_cov[k] @ jac_step.T
    return poses, cov
