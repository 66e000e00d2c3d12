"""Odometry for route mode: how far along its route each frame of a traverse was taken.

The route filter's odometry model (:mod:`nightloc.route.filter`) places the reference frames by
their cumulative distance along the route and moves the belief by the distance the query
travelled between its frames. Both come from a traverse's own records, read through
:mod:`nightloc.io`:

* ``odometry.csv``, or a bag's odometry topic (:func:`nightloc.traverse_odometry`): wheel
  odometry (``forward,left,turn``) gives a step of ``hypot(forward, left)``, negative when
  ``forward`` is (reversing); map-frame displacements (``dx,dy``) a step of ``hypot(dx, dy)``;
* otherwise poses (``poses.csv``, a video's CSV, a bag's pose topic): the distance between
  consecutive positions.

A reference's distances are the cumulative *lengths* of its steps (a route does not run
backwards); a query's advances keep the sign. Units are the records' (metres), the same in both
traverses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io.odometry_csv import ODOMETRY_FILE
from ..io.traverse import Traverse
from ..motion.odometry import MapDisplacement, RobotMotion, traverse_odometry
from .params import DISTANCE_MOTIONS, ODOMETRY_MOTION

__all__ = ["MotionPlan", "RouteOdometry", "carried_odometry", "motion_plan", "route_odometry"]


@dataclass(frozen=True)
class RouteOdometry:
    """One traverse's travel per frame.

    Attributes:
        steps: ``(N,)`` float64 distance travelled from the previous frame to each frame (0 for
            the first), negative when reversing (wheel odometry only).
        source: ``"odometry.csv"``, ``"bag odometry"`` or ``"poses"``.
    """

    steps: np.ndarray
    source: str

    @property
    def distances(self) -> np.ndarray:
        """``(N,)`` cumulative length of the steps: the frame's distance along the route."""
        return np.cumsum(np.abs(self.steps))


def _step(motion: object) -> float:
    if isinstance(motion, RobotMotion):
        return math.copysign(math.hypot(motion.forward, motion.left), motion.forward)
    if isinstance(motion, MapDisplacement):
        return math.hypot(motion.dx, motion.dy)
    return 0.0  # None: before the first frame


def route_odometry(traverse: Traverse) -> RouteOdometry | None:
    """The traverse's travel per frame from its ``odometry.csv`` (a folder's) or its bag's
    odometry, else from its poses; None when it has neither.

    Raises:
        DatasetError: an ``odometry.csv`` that cannot be read or does not fit the frames.
    """
    bag = traverse.is_bag and traverse.motions is not None
    if bag or (not traverse.is_video and not traverse.is_bag and (Path(traverse.root) / ODOMETRY_FILE).is_file()):
        motions = traverse_odometry(traverse)
        source = "bag odometry" if bag else ODOMETRY_FILE
        return RouteOdometry(np.array([_step(m) for m in motions], dtype=np.float64), source)
    positions = traverse.positions
    if positions is not None:
        xy = np.asarray(positions, dtype=np.float64)
        steps = np.r_[0.0, np.hypot(*np.diff(xy, axis=0).T)] if len(xy) else np.zeros(0)
        return RouteOdometry(steps, "poses")
    return None


@dataclass(frozen=True)
class MotionPlan:
    """Which motion model route mode runs for a pair of traverses, and why.

    Attributes:
        motion: a name of :data:`~nightloc.route.params.MOTION_MODELS`.
        advances: ``(n_query,)`` the query's steps (odometry model), else None.
        reference_distances: ``(n_ref,)`` the reference's distances (odometry model), else None.
        note: the reason in words (e.g. which traverse lacked odometry), for summaries.
        sources: ``{"reference": ..., "query": ...}``: ``"odometry.csv"``, ``"poses"`` or None.
    """

    motion: str
    advances: np.ndarray | None
    reference_distances: np.ndarray | None
    note: str
    sources: dict


def motion_plan(reference: Traverse, query: Traverse, fallback: str, use_odometry: bool = True) -> MotionPlan:
    """A model that moves by the distance travelled (``fallback`` when it is one of
    :data:`~nightloc.route.params.DISTANCE_MOTIONS`, else
    :data:`~nightloc.route.params.ODOMETRY_MOTION`) when both traverses carry odometry (and
    ``use_odometry``), else ``fallback`` (the parameters' ``filter_motion``) with the reason. A
    ``fallback`` that moves by the distance travelled without odometry in both traverses (or with
    ``use_odometry`` False) is a ValueError naming what is missing."""
    plan = _plan(reference, query, fallback, use_odometry)
    if fallback in DISTANCE_MOTIONS and plan.advances is None:
        raise ValueError(
            f"the {fallback} motion model needs odometry in both traverses (odometry.csv, a bag's odometry, or "
            f"poses), but {plan.note}; choose another motion model (--motion, filter_motion)"
        )
    return plan


def _plan(reference: Traverse, query: Traverse, fallback: str, use_odometry: bool) -> MotionPlan:
    if not use_odometry:
        return MotionPlan(fallback, None, None, "odometry not used", {"reference": None, "query": None})
    ref_odometry, query_odometry = route_odometry(reference), route_odometry(query)
    sources = {
        "reference": None if ref_odometry is None else ref_odometry.source,
        "query": None if query_odometry is None else query_odometry.source,
    }
    if ref_odometry is not None and query_odometry is not None:
        distances = ref_odometry.distances
        if not distances[-1] > distances[0]:
            note = f"the reference's {ref_odometry.source} says it never moved"
            return MotionPlan(fallback, None, None, note, sources)
        note = f"reference {ref_odometry.source}, query {query_odometry.source}"
        motion = fallback if fallback in DISTANCE_MOTIONS else ODOMETRY_MOTION
        return MotionPlan(motion, query_odometry.steps, distances, note, sources)
    if ref_odometry is None and query_odometry is None:
        return MotionPlan(fallback, None, None, "neither traverse has odometry.csv or poses", sources)
    side, other = ("query", "reference") if query_odometry is not None else ("reference", "query")
    return MotionPlan(fallback, None, None, f"odometry in the {side} only (the {other} has none)", sources)


def carried_odometry(reference: Traverse, query: Traverse) -> tuple[np.ndarray, np.ndarray] | None:
    """``(query advances, reference distances)`` when both traverses carry odometry and the
    reference moves (what the odometry model would run on, whichever model runs), else None."""
    plan = _plan(reference, query, "odometry", True)
    if plan.advances is None or plan.reference_distances is None:
        return None
    return plan.advances, plan.reference_distances
