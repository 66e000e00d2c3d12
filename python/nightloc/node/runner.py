"""Frames localized one at a time, as ``nightloc localize`` localizes a log and as the node
localizes a live stream: each frame prepared with the map's parameters, then the grid filter's
update (or, when the night is learned, :class:`~nightloc.experience.learning.NightLearner`'s, the
update ``localize --learn`` runs), and whether the belief has converged.
"""

from __future__ import annotations

import math

import numpy as np

from ..experience.learning import LearningParams, LearningReport, NightLearner, learn
from ..localization.localizer import Estimate, Localizer
from ..mapping.reference_map import ReferenceMap

__all__ = ["DEFAULT_CONVERGED_CONFIDENCE", "FrameLocalizer"]

#: The confidence (belief within the confidence radius) from which ``map -> odom`` is published.
DEFAULT_CONVERGED_CONFIDENCE = 0.8


class FrameLocalizer:
    """A filter :class:`Localizer` driven frame by frame.

    Args:
        localizer: the filter over the map (``method="filter"``); reset first.
        learn: keep every frame for :meth:`learned_map` (what ``localize --learn`` learns from).
        converged_confidence: :attr:`converged` from this confidence on (0..1).
    """

    def __init__(
        self, localizer: Localizer, *, learn: bool = False, converged_confidence: float = DEFAULT_CONVERGED_CONFIDENCE
    ):
        if not 0.0 <= converged_confidence <= 1.0:
            raise ValueError(f"the converged confidence must be in [0, 1], got {converged_confidence}")
        self.localizer = localizer
        self.ref_map: ReferenceMap = localizer.ref_map
        self.learner = NightLearner(self.ref_map, localizer) if learn else None
        if self.learner is None:
            localizer.reset()
        self.converged_confidence = converged_confidence
        self.converged = False
        self.names: list[str] = []
        self.timestamps: list[float] = []

    def prepare(self, frame: np.ndarray) -> np.ndarray:
        """The frame prepared with the map's parameters, ``(Ry, Rx)`` uint8."""
        return self.ref_map.preparer.prepare(frame)

    def step(self, prepared: np.ndarray, motion: object, name: str = "", timestamp: float = math.nan) -> Estimate:
        """Localizes one prepared frame with ``motion`` since the previous one (see
        :meth:`Localizer.update`); updates :attr:`converged`."""
        if self.learner is not None:
            estimate = self.learner.step(prepared, motion, prepared=True)
            self.names.append(name or f"frame_{len(self.names):06d}")
            self.timestamps.append(float(timestamp))
        else:
            estimate = self.localizer.update(prepared, motion, prepared=True)
        self.converged = bool(math.isfinite(estimate.confidence) and estimate.confidence >= self.converged_confidence)
        return estimate

    def relocalize(self) -> None:
        """The belief becomes uniform (a global relocalization): not converged until it settles."""
        self.localizer.reset()
        self.converged = False

    def set_pose(self, x: float, y: float, heading: float, covariance: np.ndarray) -> None:
        """The belief becomes that Gaussian (see :meth:`Localizer.set_pose`)."""
        self.localizer.set_pose(x, y, heading, covariance)
        self.converged = False

    def learned_map(self, source: str, params: LearningParams | None = None) -> tuple[ReferenceMap, LearningReport]:
        """The map plus what the frames so far taught it (:func:`~nightloc.experience.learning.learn`)."""
        if self.learner is None:
            raise RuntimeError("this FrameLocalizer was made without learn=True")
        times = np.asarray(self.timestamps, dtype=np.float64)
        night = self.learner.night(self.names, times if np.isfinite(times).all() else None, source)
        return learn(self.ref_map, night, params)
