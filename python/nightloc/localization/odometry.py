"""The odometry types under the localization stage's name: they live in
:mod:`nightloc.motion.odometry`, the motion stage shared by localization, mapping, route and synth."""

from __future__ import annotations

from ..motion.odometry import (
    NOISE_MODELS,
    WHEEL_ODOMETRY_NOISE,
    MapDisplacement,
    Motion,
    NoiseModel,
    RobotMotion,
    as_motion,
    compose_motions,
    log_noise_model,
    noise_model,
    read_odometry,
    reverse_motion,
    robot_steps_to_map,
    simulate_map_odometry,
    simulate_robot_odometry,
    traverse_odometry,
    true_map_steps,
    true_robot_motions,
    wrap_angle,
)

__all__ = [
    "NOISE_MODELS",
    "WHEEL_ODOMETRY_NOISE",
    "MapDisplacement",
    "Motion",
    "NoiseModel",
    "RobotMotion",
    "as_motion",
    "compose_motions",
    "log_noise_model",
    "noise_model",
    "read_odometry",
    "reverse_motion",
    "robot_steps_to_map",
    "simulate_map_odometry",
    "simulate_robot_odometry",
    "traverse_odometry",
    "true_map_steps",
    "true_robot_motions",
    "wrap_angle",
]
