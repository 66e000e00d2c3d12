"""Route mode: 1D localization along long traverses -- a causal Bayes filter over the reference
frames (the default), and SeqSLAM exact against OpenSeqSLAM and far faster.

The paper's creek experiment (Mount & Milford 2016, section IV-D) localizes a night traverse
against a day traverse of the same route with classic sequence matching. This subpackage builds
that pipeline over the compiled core:

* :func:`match_route` / :func:`match_prepared`: difference matrix (circular shifts for panoramas,
  shift 0 for forward cameras), local contrast enhancement, then
  - the route filter (``method="filter"``, :mod:`~nightloc.route.filter`): a causal belief over
    the references, predicted by a motion model (the robot's odometry when both traverses carry
    it, :mod:`~nightloc.route.odometry`; else a speed that changes, or a speed window) and
    updated by each frame's row; or
  - SeqSLAM (``method="seqslam"``): straight-line trajectory search over a range of speeds,
    uniqueness ratio; centred (OpenSeqSLAM) or causal trajectories;
* :class:`RouteParams` and the presets ``"openseqslam"`` (bit-exact with OpenSeqSLAM under
  Octave) and ``"nightloc"`` (the paper's image preparation without equalization, the filter);
* :class:`RouteLocalizer`: causal, frame-by-frame localization for a robot;
* :mod:`~nightloc.route.evaluation`: ground truth from frames or positions, precision-recall,
  recall at 100 % precision, best F1 (the figures are :mod:`nightloc.figures.route`'s);
* :mod:`~nightloc.route.dask_backend`: the difference matrix and enhancement blocked on a Dask
  cluster (optional extra ``nightloc[dask]``).
"""

from __future__ import annotations

from .evaluation import GroundTruth, PRCurve, RouteEvaluation, evaluate_matches, precision_recall
from .filter import FilterStep, RouteFilter, motion_kernel, route_filter, route_filter_run, texture_weights
from .localizer import RouteLocalizer, RouteUpdate
from .odometry import MotionPlan, RouteOdometry, motion_plan, route_odometry
from .params import MOTION_MODELS, PRESETS, RouteParams, default_preparation, resolve_params, route_preset
from .pipeline import (
    RouteResult,
    enhance_contrast,
    match_difference,
    match_prepared,
    match_route,
    route_difference_matrix,
    trajectory_search,
)
from .preparation import RoutePreparer, octave_rgb2gray

__all__ = [
    "MOTION_MODELS",
    "PRESETS",
    "FilterStep",
    "GroundTruth",
    "MotionPlan",
    "PRCurve",
    "RouteEvaluation",
    "RouteFilter",
    "RouteLocalizer",
    "RouteOdometry",
    "RouteParams",
    "RoutePreparer",
    "RouteResult",
    "RouteUpdate",
    "default_preparation",
    "enhance_contrast",
    "evaluate_matches",
    "match_difference",
    "match_prepared",
    "match_route",
    "motion_kernel",
    "motion_plan",
    "octave_rgb2gray",
    "precision_recall",
    "resolve_params",
    "route_difference_matrix",
    "route_filter",
    "route_filter_run",
    "route_odometry",
    "route_preset",
    "texture_weights",
    "trajectory_search",
]
