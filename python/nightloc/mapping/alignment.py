"""Rigid 2D alignment of two sets of positions, and the absolute trajectory error (ATE).

A teach run's map lives in the frame of the robot's own odometry (its first pose at the
origin, heading 0), a survey in another; comparing them needs the rotation and translation
that best bring one onto the other: :func:`rigid_fit` (least squares, no scale: the
Kabsch/Umeyama solution in 2D). The ATE is the RMSE of the positions after that fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["RigidTransform2D", "absolute_trajectory_error", "rigid_fit"]


@dataclass(frozen=True)
class RigidTransform2D:
    """``p' = R(rotation) @ p + translation``: a rotation (radians, counter-clockwise) then a
    translation (metres)."""

    rotation: float = 0.0
    translation: tuple[float, float] = (0.0, 0.0)

    @property
    def matrix(self) -> np.ndarray:
        """``(2, 2)`` rotation matrix."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        return np.array([[c, -s], [s, c]])

    def apply(self, points: np.ndarray) -> np.ndarray:
        """``(N, 2)`` (or ``(2,)``) positions moved by the transform."""
        pts = np.asarray(points, dtype=np.float64)
        return pts @ self.matrix.T + np.asarray(self.translation)

    def apply_headings(self, headings: np.ndarray) -> np.ndarray:
        """Headings (radians) turned by the rotation, wrapped to (-pi, pi]."""
        turned = np.asarray(headings, dtype=np.float64) + self.rotation
        return np.pi - np.mod(np.pi - turned, 2 * np.pi)

    def inverse(self) -> RigidTransform2D:
        """The transform that undoes this one."""
        back = -(self.matrix.T @ np.asarray(self.translation))
        return RigidTransform2D(-self.rotation, (float(back[0]), float(back[1])))


def _pairs(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(source, dtype=np.float64)
    b = np.asarray(target, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 2 or a.shape != b.shape:
        raise ValueError(f"positions must be two (N, 2) arrays of the same shape, got {a.shape} and {b.shape}")
    if len(a) < 2:
        raise ValueError("a rigid fit needs at least 2 positions")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ValueError("positions hold NaN or infinity")
    return a, b


def rigid_fit(source: np.ndarray, target: np.ndarray) -> RigidTransform2D:
    """The rotation and translation (no scale) minimizing ``sum |T(source_k) - target_k|^2``.

    Args:
        source, target: ``(N, 2)`` corresponding positions (metres), N >= 2.

    Returns:
        :class:`RigidTransform2D` taking ``source`` onto ``target``.
    """
    a, b = _pairs(source, target)
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    da, db = a - ca, b - cb
    # 2D Kabsch in closed form: the angle maximizing sum(db . R da)
    rotation = math.atan2(float(np.sum(da[:, 0] * db[:, 1] - da[:, 1] * db[:, 0])), float(np.sum(da * db)))
    c, s = math.cos(rotation), math.sin(rotation)
    t = cb - np.array([[c, -s], [s, c]]) @ ca
    return RigidTransform2D(rotation, (float(t[0]), float(t[1])))


def absolute_trajectory_error(estimate: np.ndarray, truth: np.ndarray) -> float:
    """RMSE (metres) of ``estimate`` after the best rigid 2D fit onto ``truth`` (both ``(N, 2)``)."""
    a, b = _pairs(estimate, truth)
    moved = rigid_fit(a, b).apply(a)
    return float(np.sqrt(np.mean(np.sum((moved - b) ** 2, axis=1))))
