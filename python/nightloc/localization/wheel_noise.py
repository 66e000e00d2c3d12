"""The wheel-odometry error model under the localization stage's name: it lives in
:mod:`nightloc.motion.wheel_noise`, the motion stage shared by localization, mapping, route and synth."""

from __future__ import annotations

from ..motion.wheel_noise import WheelNoise

__all__ = ["WheelNoise"]
