"""The teach run's pose graph in GTSAM: one ``Pose2`` per frame and its factors.

* a prior fixing frame 0 at the origin of the map frame (heading 0): the map frame is the
  day drive's odometry frame;
* an **odometry** factor between consecutive frames (``BetweenFactorPose2``), the measured
  step ``(forward, left, turn)`` with the wheel-noise model's covariance;
* a **visual** factor per :class:`~nightloc.mapping.candidates.VisualConstraint`: the relative
  heading (a ``BetweenFactorPose2`` whose translation is free, standard deviation
  :data:`FREE_TRANSLATION_STD`); for a strong place pair, heading and coinciding positions; for
  a pair placed along the other frame's pass, heading and that one position component (the
  information matrix of ``BetweenFactorPose2(j, i)`` along ``j``'s direction of travel); all
  under a Cauchy robust kernel, so a false match pulls with a bounded force;
* optionally the **closed loop**: the last frame's position is the first's (a dock).

GTSAM (PyPI ``gtsam``) is an optional dependency (``pip install "nightloc[mapping]"``):
:func:`require_gtsam` imports it or raises one :class:`~nightloc.errors.MissingDependencyError`
naming the install command.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from ..errors import MissingDependencyError
from .candidates import VisualConstraint

__all__ = ["FREE_TRANSLATION_STD", "INSTALL_HINT", "build_graph", "require_gtsam"]

#: How to install the teach run's optimiser.
INSTALL_HINT = 'pip install "nightloc[mapping]"  (or: pip install gtsam)'
#: Metres: the standard deviation that leaves a heading-only factor's translation free.
FREE_TRANSLATION_STD = 1.0e3
#: The prior on frame 0 (metres, radians): the map frame's origin.
ORIGIN_STD = 1.0e-6


def require_gtsam() -> ModuleType:
    """The ``gtsam`` module, or MissingDependencyError naming the install command."""
    try:
        import gtsam
    except ImportError as error:
        raise MissingDependencyError(
            f"the teach run optimises its pose graph with GTSAM, which is not installed ({error}); "
            f"install it with: {INSTALL_HINT}"
        ) from None
    return gtsam


def _robust(gtsam: ModuleType, base: Any, scale: float) -> Any:
    return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Cauchy.Create(scale), base)


def _along_factor(gtsam: ModuleType, c: VisualConstraint, robust_scale: float) -> Any:
    """``BetweenFactorPose2(j, i)``: ``i`` lies ``c.along`` metres along ``j``'s direction of
    travel (free across it), turned by ``-c.heading``."""
    u = np.array([np.cos(c.along_direction), np.sin(c.along_direction)])
    info = np.zeros((3, 3))
    info[:2, :2] = np.outer(u, u) / c.along_std**2 + np.eye(2) / FREE_TRANSLATION_STD**2
    info[2, 2] = 1.0 / c.heading_std**2
    along = float(c.along)  # type: ignore[arg-type]  # set for this kind of constraint
    measured = gtsam.Pose2(along * u[0], along * u[1], -c.heading)
    noise = _robust(gtsam, gtsam.noiseModel.Gaussian.Information(info), robust_scale)
    return gtsam.BetweenFactorPose2(c.j, c.i, measured, noise)


def build_graph(
    steps: np.ndarray,
    step_covariances: np.ndarray,
    constraints: list[VisualConstraint],
    *,
    robust_scale: float,
    closed_loop_std: float | None = None,
) -> Any:
    """The ``gtsam.NonlinearFactorGraph`` of a drive of ``len(steps) + 1`` frames.

    Args:
        steps: ``(N - 1, 3)`` measured robot-frame steps ``(forward, left, turn)``.
        step_covariances: ``(N - 1, 3, 3)`` their covariances.
        constraints: visual constraints.
        robust_scale: the Cauchy kernel's scale, in standard deviations.
        closed_loop_std: metres: the last frame is at the first's position; None: no such factor.
    """
    gtsam = require_gtsam()
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(0.0, 0.0, 0.0), gtsam.noiseModel.Isotropic.Sigma(3, ORIGIN_STD)))
    for k, (step, cov) in enumerate(zip(steps, step_covariances)):
        noise = gtsam.noiseModel.Gaussian.Covariance(np.asarray(cov, dtype=np.float64))
        graph.add(gtsam.BetweenFactorPose2(k, k + 1, gtsam.Pose2(*(float(v) for v in step)), noise))
    for c in constraints:
        if c.along is not None and c.position_std is None:
            graph.add(_along_factor(gtsam, c, robust_scale))
            continue
        position_std = FREE_TRANSLATION_STD if c.position_std is None else c.position_std
        base = gtsam.noiseModel.Diagonal.Sigmas(np.array([position_std, position_std, c.heading_std]))
        noise = _robust(gtsam, base, robust_scale)
        graph.add(gtsam.BetweenFactorPose2(c.i, c.j, gtsam.Pose2(0.0, 0.0, c.heading), noise))
    if closed_loop_std is not None and len(steps) > 0:
        base = gtsam.noiseModel.Diagonal.Sigmas(np.array([closed_loop_std, closed_loop_std, FREE_TRANSLATION_STD]))
        graph.add(gtsam.BetweenFactorPose2(0, len(steps), gtsam.Pose2(0.0, 0.0, 0.0), base))
    return graph
