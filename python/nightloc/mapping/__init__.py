"""The reference map, and the teach run: a reference map from the robot's own day drive, without a survey.

* :mod:`~nightloc.mapping.reference_map` — :class:`ReferenceMap` (``nightloc.ReferenceMap``): build,
  match, save, load;
* :mod:`~nightloc.mapping.dead_reckoning` — wheel odometry chained into poses, with covariance;
* :mod:`~nightloc.mapping.params` — :class:`TeachParams` (TOML ``[teach]``);
* :mod:`~nightloc.mapping.visual` — relative heading of two panoramas to a fraction of a column;
* :mod:`~nightloc.mapping.warping` — relative heading and direction of travel by min-warping;
* :mod:`~nightloc.mapping.candidates` — which frames see the same place; visual constraints;
* :mod:`~nightloc.mapping.factors` — the GTSAM pose graph (odometry, visual, closed-loop factors);
* :mod:`~nightloc.mapping.optimiser` — headings, then positions, then the whole graph; marginals;
* :mod:`~nightloc.mapping.alignment` — rigid 2D fit and absolute trajectory error (ATE);
* :mod:`~nightloc.mapping.teach` — :func:`teach_run`, the whole teach run.

Experience maps (a map that learns from its nights) localize as well as map: they are the stage
:mod:`nightloc.experience`, above localization.

GTSAM is optional: ``pip install "nightloc[mapping]"``.
"""

from __future__ import annotations

from .alignment import RigidTransform2D, absolute_trajectory_error, rigid_fit
from .params import TeachParams
from .reference_map import ReferenceMap
from .teach import TeachReport, TeachWarning, teach_run

__all__ = [
    "ReferenceMap",
    "RigidTransform2D",
    "TeachParams",
    "TeachReport",
    "TeachWarning",
    "absolute_trajectory_error",
    "rigid_fit",
    "teach_run",
]
