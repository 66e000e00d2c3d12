"""2D localization (paper III-D..F): heat maps, sequences of heat maps, odometry, the streaming
localizer and the evaluation of localization runs.

* :mod:`~nightloc.localization.heatmap` — scores to heat maps on a regular grid (eq. 4);
* :mod:`~nightloc.localization.sequence` — heat maps translated by odometry and summed;
* :mod:`~nightloc.localization.odometry` — motions, Table III noise models, simulation;
* :mod:`~nightloc.localization.localizer` — :class:`Localizer`, the per-frame API;
* :mod:`~nightloc.localization.evaluation` — distance errors over sequence lengths and noise.
"""

from __future__ import annotations

from .localizer import Estimate, LocalizationParams, Localizer
from .odometry import MapDisplacement, NoiseModel, RobotMotion

__all__ = ["Estimate", "LocalizationParams", "Localizer", "MapDisplacement", "NoiseModel", "RobotMotion"]
