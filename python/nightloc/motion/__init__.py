"""Motion: how the robot moved between frames, shared by localization, mapping, route and synth.

* :mod:`~nightloc.motion.odometry` — motions (map-frame displacements, robot-frame wheel
  motions), the paper's Table III noise models, odometry simulated from ground truth, a log's
  ``odometry.csv`` read into motions;
* :mod:`~nightloc.motion.wheel_noise` — :class:`WheelNoise`, a wheel-encoder error model (scale,
  turn bias, slip) that simulates a drive's odometry and gives the teach run its step covariance.
"""

from __future__ import annotations

from .odometry import MapDisplacement, NoiseModel, RobotMotion, traverse_odometry
from .wheel_noise import WheelNoise

__all__ = ["MapDisplacement", "NoiseModel", "RobotMotion", "WheelNoise", "traverse_odometry"]
