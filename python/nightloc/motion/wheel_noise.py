"""A realistic wheel-odometry error model, apart from the paper's Table III.

The paper's Table III draws independent Gaussian noise per step. Real wheel encoders err
differently: a wrong wheel radius scales every step of a run by the same factor, a wheel-base
or tyre-pressure mismatch turns the robot a little on every step (a turn *bias*), and slip adds
independent noise per step on top. :class:`WheelNoise` holds those four terms, draws noisy
wheel odometry from ground-truth poses (:meth:`WheelNoise.simulate`, used by :mod:`nightloc.synth`
for every drive's ``odometry.csv``) and gives the per-step covariance that the teach run's
odometry factors use (:meth:`WheelNoise.step_sigmas`, :mod:`nightloc.mapping`).

Defaults (a measured wheel base, docs/teach_run.md): per-run scale error ``N(0, 3 %)``, per-step
distance noise 3 % of the step, per-step turn noise ``N(0, 0.05 rad)``, per-run turn bias
``N(0, 0.01 rad/step)``.

For a step with true robot-frame motion ``(forward, left, turn)`` and length ``d``::

    factor   = 1 + scale + N(0, distance_std)         scale ~ N(0, scale_std) once per run
    forward' = forward * factor,  left' = left * factor
    turn'    = turn + bias + N(0, turn_std)           bias ~ N(0, turn_bias_std) once per run
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .odometry import RobotMotion, true_robot_motions

__all__ = ["WheelNoise"]


@dataclass(frozen=True)
class WheelNoise:
    """Wheel-odometry error model (all standard deviations of zero-mean Gaussians).

    Attributes:
        scale_std: per-run scale error of every step's length (fraction; 0.03 = 3 %).
        distance_std: per-step length noise (fraction of the step).
        turn_std: per-step turn noise, radians.
        turn_bias_std: per-run turn bias, radians per step.
        min_distance_std: metres; the floor of a step's length noise (a robot that stands still
            still jitters a little); used for the factors' covariance only.
        min_turn_std: radians; the floor of a step's turn noise in the factors' covariance.
    """

    scale_std: float = 0.03
    distance_std: float = 0.03
    turn_std: float = 0.05
    turn_bias_std: float = 0.01
    min_distance_std: float = 0.005
    min_turn_std: float = 0.002

    def __post_init__(self) -> None:
        for name in ("scale_std", "distance_std", "turn_std", "turn_bias_std", "min_distance_std", "min_turn_std"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise TypeError(f"WheelNoise.{name} must be a number, got {type(value).__name__}")
            if not (math.isfinite(float(value)) and value >= 0):
                raise ValueError(f"WheelNoise.{name} must be a finite number >= 0, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.scale_std >= 0.5 or self.distance_std >= 0.5:
            raise ValueError("WheelNoise scale_std and distance_std are fractions of a step; keep them below 0.5")

    def simulate(
        self, positions: np.ndarray, headings: np.ndarray, rng: np.random.Generator | int | None = None
    ) -> list[RobotMotion]:
        """Noisy wheel odometry between consecutive ground-truth poses.

        Args:
            positions: ``(N, 2)`` metres; headings: ``(N,)`` radians.
            rng: a generator or a seed; the per-run scale and bias are drawn first, then the
                per-step noise (so a longer drive with the same seed shares its run's errors).

        Returns:
            N :class:`~nightloc.RobotMotion`; element 0 is zero motion (nothing before frame 0).
        """
        truth = true_robot_motions(positions, headings)
        generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        scale = generator.normal(0.0, self.scale_std) if self.scale_std > 0 else 0.0
        bias = generator.normal(0.0, self.turn_bias_std) if self.turn_bias_std > 0 else 0.0
        n = len(truth) - 1
        length_noise = generator.normal(0.0, 1.0, n) * self.distance_std
        turn_noise = generator.normal(0.0, 1.0, n) * self.turn_std
        out = [truth[0]]
        for k, motion in enumerate(truth[1:]):
            factor = 1.0 + scale + float(length_noise[k])
            out.append(
                RobotMotion(motion.forward * factor, motion.left * factor, motion.turn + bias + float(turn_noise[k]))
            )
        return out

    def step_covariances(self, forward: np.ndarray, left: np.ndarray) -> np.ndarray:
        """``(n, 3, 3)`` covariances of measured steps ``(forward, left, turn)`` in the robot frame
        at the step's start: along the step its length noise and the run's scale (metres),
        across it half the step's turn noise swinging its direction (metres), and the turn's
        noise and bias (radians); the teach run's odometry factors.

        Args:
            forward, left: ``(n,)`` measured step components, metres.
        """
        fwd = np.atleast_1d(np.asarray(forward, np.float64))
        lft = np.atleast_1d(np.asarray(left, np.float64))
        length = np.hypot(fwd, lft)
        turn = math.hypot(math.hypot(self.turn_std, self.turn_bias_std), self.min_turn_std)
        along = np.hypot(length * math.hypot(self.distance_std, self.scale_std), self.min_distance_std)
        across = np.hypot(length * turn / 2.0, self.min_distance_std)
        direction = np.arctan2(lft, fwd)
        c, s = np.cos(direction), np.sin(direction)
        cov = np.zeros((len(length), 3, 3))
        cov[:, 0, 0] = c * c * along**2 + s * s * across**2
        cov[:, 1, 1] = s * s * along**2 + c * c * across**2
        cov[:, 0, 1] = cov[:, 1, 0] = c * s * (along**2 - across**2)
        cov[:, 2, 2] = turn**2
        return cov
