"""2D localization (paper III-D..F): heat maps, sequences of heat maps, odometry, the streaming
localizer and the evaluation of localization runs.

* :mod:`~nightloc.localization.heatmap` — scores to heat maps on a regular grid (eq. 4);
* :mod:`~nightloc.localization.sequence` — heat maps translated by odometry and summed;
* :mod:`~nightloc.localization.odometry` — the motion types of :mod:`nightloc.motion`, under this stage's name;
* :mod:`~nightloc.localization.grid_filter` — the recursive grid Bayes filter (the default method);
* :mod:`~nightloc.localization.localizer` — :class:`Localizer`, the per-frame API;
* :mod:`~nightloc.localization.evaluation` — distance errors over sequence lengths and noise;
* :mod:`~nightloc.localization.filter_tables` — the default localizer's tables that map files carry.
"""

from __future__ import annotations

from ..mapping.reference_map import set_localizer_tables
from .filter_tables import filter_tables
from .grid_filter import FilterParams
from .localizer import Estimate, LocalizationParams, Localizer
from .odometry import MapDisplacement, NoiseModel, RobotMotion, traverse_odometry

# A map file carries the default localizer's tables (map format 3): this stage makes them.
set_localizer_tables(filter_tables)

__all__ = [
    "Estimate",
    "FilterParams",
    "LocalizationParams",
    "Localizer",
    "MapDisplacement",
    "NoiseModel",
    "RobotMotion",
    "traverse_odometry",
]
