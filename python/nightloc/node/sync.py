"""Odometry matched to frames by their stamps, as the bag reader matches a log's: the samples
around a frame's stamp interpolated (:func:`nightloc.io.bag.interpolate_poses`), the motion since
the previous frame in the robot's frame (:func:`nightloc.io.bag.robot_motions`).

A live stream arrives in pieces, so :class:`OdometrySync` keeps a bounded window of samples:
those from shortly before the last frame's stamp on. A frame is ready once a sample at or after
its stamp has arrived (else the caller may wait for one, or take the nearest within the
tolerance, as the bag reader does at a stream's end).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from ..errors import DatasetError
from ..io.bag import interpolate_poses, robot_motions
from ..motion.odometry import NoiseModel, RobotMotion

__all__ = ["MAX_SAMPLES", "OdometrySync"]

#: Samples kept at most (about a minute of 100 Hz odometry: bounded whatever the stamps do).
MAX_SAMPLES = 6000

Pose2D = tuple[float, float, float]


class OdometrySync:
    """Odometry samples ``(stamp s, x, y, yaw)`` of the base frame in the odom frame, each with its
    twist's variances (forward speed, sideways speed, yaw rate; zeros: unknown), and the pose of
    the last frame.

    Args:
        tolerance: seconds; a frame farther than this from every sample has no odometry.
    """

    def __init__(self, tolerance: float):
        self.tolerance = float(tolerance)
        self._samples: deque[tuple[float, float, float, float]] = deque(maxlen=MAX_SAMPLES)
        self._twist: deque[tuple[float, float, float]] = deque(maxlen=MAX_SAMPLES)
        self._last: tuple[float, Pose2D] | None = None  # the last frame's stamp and odometry pose

    @property
    def newest(self) -> float | None:
        """The newest sample's stamp (s), or None."""
        return self._samples[-1][0] if self._samples else None

    def add(self, stamp: float, pose: Pose2D, twist_variances: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> str:
        """Adds a sample; returns "" or a line saying what was wrong with it (a non-finite value; a
        stamp before the newest sample's: the window is cleared, as after a clock jump)."""
        values = (stamp, *pose)
        if not all(math.isfinite(v) for v in values):
            return f"an odometry sample with a non-finite value ({', '.join(f'{v:g}' for v in values)}) is ignored"
        problem = ""
        if self._samples and stamp < self._samples[-1][0]:
            problem = (
                f"the odometry's stamps went back in time ({stamp:.6f} s after {self._samples[-1][0]:.6f} s): its "
                f"earlier samples are dropped and the next frame's motion is unknown"
            )
            self._samples.clear()
            self._twist.clear()
            self._last = None
        self._samples.append((float(stamp), float(pose[0]), float(pose[1]), float(pose[2])))
        self._twist.append(tuple(float(v) for v in twist_variances))  # type: ignore[arg-type]
        return problem

    def covers(self, stamp: float) -> bool:
        """Whether a sample at or after ``stamp`` has arrived."""
        return bool(self._samples) and self._samples[-1][0] >= stamp

    def pose_at(self, stamp: float) -> Pose2D:
        """The odometry's pose at ``stamp`` (interpolated; the nearest sample within the tolerance
        beyond the ends). DatasetError when no sample lies within the tolerance."""
        if not self._samples:
            raise DatasetError("no odometry has arrived")
        samples = np.array(self._samples, dtype=np.float64)
        pose = interpolate_poses(
            samples[:, 0], samples[:, 1:], np.array([stamp]), self.tolerance, "the odometry", "the frame"
        )[0]
        return (float(pose[0]), float(pose[1]), float(pose[2]))

    def motion(self, stamp: float, pose: Pose2D) -> RobotMotion | None:
        """The robot-frame motion from the last frame's odometry pose to ``pose`` (this frame's, at
        ``stamp``), and remembers this frame; None for the first frame (or after a clock jump)."""
        last = self._last
        self._last = (stamp, pose)
        self._prune(stamp)
        if last is None:
            return None
        forward, left, turn = robot_motions(np.array([last[1], pose]))[1]
        return RobotMotion(float(forward), float(left), float(turn))

    def forget_last(self) -> None:
        """The next frame's motion is unknown (its predecessor was skipped for its stamp)."""
        self._last = None

    def step_noise(self, stamp: float, seconds: float) -> NoiseModel | None:
        """The noise of a step of ``seconds`` from the twist covariance of the sample nearest
        ``stamp``: ``sqrt(var_vx + var_vy) * seconds`` metres, ``sqrt(var_wz) * seconds`` radians;
        None when it is all zeros (unknown)."""
        if not self._samples:
            return None
        stamps = np.fromiter((s[0] for s in self._samples), dtype=np.float64, count=len(self._samples))
        vx, vy, wz = self._twist[int(np.argmin(np.abs(stamps - stamp)))]
        if vx == 0 and vy == 0 and wz == 0:
            return None
        return NoiseModel(math.sqrt(max(vx + vy, 0.0)) * seconds, math.sqrt(max(wz, 0.0)) * seconds)

    def _prune(self, stamp: float) -> None:
        """Drops the samples no later frame needs (keeping the last one before ``stamp`` minus the
        tolerance)."""
        horizon = stamp - self.tolerance
        while len(self._samples) > 2 and self._samples[1][0] < horizon:
            self._samples.popleft()
            self._twist.popleft()
