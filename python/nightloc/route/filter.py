"""Route mode's Bayes filter: a causal belief over the reference frames of a route.

The probabilistic successor of SeqSLAM's trajectory search (``RouteParams.method = "filter"``,
the default). The belief ``b[r]`` = P(the current query frame shows reference r), plus an
off-route probability, is carried from frame to frame:

1. **predict** by a motion model (``docs/route_mode.md``; the names in
   :data:`~nightloc.route.params.MOTION_MODELS`): *odometry* when given the references'
   distances along the route and each query's advance (the belief on cells of a reference, each
   moved by the distance travelled, with relative noise ``filter_odometry_noise``); else
   ``filter_motion``: the *window* (the reference advances by
   ``floor(x + v)`` for a speed v uniform in ``vmin .. vmax`` references per frame and a
   sub-frame phase x uniform in [0, 1), :func:`motion_kernel`; default 0.8 .. 1.2: P(0) =
   P(2) = 0.05, P(1) = 0.9) or the *speed* model (a belief over position x speed planes, the
   speed a random walk pulled back towards 1, ``filter_speed_*``); with probability
   ``filter_backward`` the reference steps back one instead; ``filter_floor`` of the belief is spread
   uniformly over the route (a lost filter finds the route again); ``filter_leave`` of the
   on-route mass leaves the route and ``filter_rejoin`` of the off-route mass comes back,
   uniformly.
2. **update**: the frame's row of the contrast-enhanced difference matrix is standardized by its
   own mean and standard deviation, ``z = (d - mean) / std`` (the likelihood's scale follows the
   spread of each row: a night frame whose differences all look alike gets no sharper a
   likelihood than a day frame); ``L[r] = exp(-lambda * min(z[r], clip))`` with
   ``lambda = filter_sharpness * weight``; the off-route state's likelihood is the mean of L (a
   frame that matches nothing looks like a random place). ``weight`` =
   ``min(1, texture / filter_min_texture)`` from the prepared query's mean absolute deviation
   (:func:`texture_weights`): a flat frame (a lens cap, a saturated or black image) leaves the
   belief as predicted. NaN entries (the enhancement of a constant window, e.g. a tunnel of
   identical black references) count as z = 0.
3. **answer**: the most probable reference; confidence = the belief within ``filter_window``
   references of it, the score of the precision-recall curve (``score = 1 - confidence``,
   lower = more confident, as SeqSLAM's); the off-route probability.

The parameters were chosen on Nordland (summer/winter) and Gardens Point (day/night) together,
including queries with a varying speed and kidnaps (``docs/route_mode.md``). The per-frame cost is
a few passes over ``n_ref`` doubles (docs/route_mode.md, "Speed", has the figures); the arithmetic is
sequential double precision, so :class:`RouteFilter` frame by frame and :func:`route_filter` over a
matrix give identical results, and ``tests/route_oracle.py`` holds a numpy oracle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _core
from .._validate import thread_count, uint8_array
from .params import DISTANCE_MOTIONS, ODOMETRY_MOTION, RouteParams, resolve_params

__all__ = [
    "FilterStep",
    "RouteFilter",
    "motion_kernel",
    "motion_name",
    "route_filter",
    "route_filter_run",
    "texture_weights",
]


def motion_kernel(vmin: float = 0.8, vmax: float = 1.2, backward: float = 0.0) -> tuple[int, np.ndarray]:
    """The filter's prediction kernel: ``(first, weights)`` with ``weights[i]`` = P(the reference
    advances by ``first + i`` in one frame); weights sum to 1 (exact closed-form integrals)."""
    first, weights = _core.motion_kernel(float(vmin), float(vmax), float(backward))
    return int(first), weights


def texture_weights(images: np.ndarray, min_texture: float = 1.0) -> np.ndarray:
    """``(n,)`` float64 evidence weights ``min(1, mad / min_texture)`` of ``(n, H, W)`` uint8
    prepared images, ``mad`` = mean absolute deviation of an image's pixels from their mean (grey
    levels); a flat image gives 0, ``min_texture = 0`` gives 1 for every image."""
    stack = uint8_array(images, 3, "images")
    if not (np.isfinite(min_texture) and min_texture >= 0):
        raise ValueError(f"min_texture must be >= 0 grey levels, got {min_texture}")
    return _core.texture_weights(stack, float(min_texture))


def route_filter(
    matrix: np.ndarray,
    params: RouteParams | str | None = None,
    weights: np.ndarray | None = None,
    threads: int | None = None,
    *,
    advances: np.ndarray | None = None,
    reference_distances: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The filter over a whole ``(n_query, n_ref)`` float32 matrix (query rows in time order,
    lower = more similar; route mode passes the contrast-enhanced difference matrix), from the
    prior belief.

    Args:
        matrix: ``(M, N)`` float32 C-contiguous.
        params: :class:`RouteParams` or a preset name (its ``vmin``, ``vmax`` and ``filter_*``).
        weights: optional ``(M,)`` evidence weights in [0, 1] (:func:`texture_weights`).
        threads: threads for the rows' likelihoods (None: all cores); the updates run in order
            on one. The result does not depend on it.
        advances, reference_distances: the odometry model (both or neither): ``(M,)`` distance
            each query travelled since the previous one (the first is ignored; negative:
            backwards) and ``(N,)`` cumulative distance of each reference along the route
            (non-decreasing), in one unit (:mod:`nightloc.route.odometry` reads them from
            traverses).

    Returns:
        ``(refs, confidence, off_route)``: ``(M,)`` int64 most probable reference, float64 belief
        within ``filter_window`` of it, float64 off-route probability.
    """
    return route_filter_run(matrix, params, weights, threads, advances, reference_distances)[:3]


def route_filter_run(
    matrix: np.ndarray,
    params: RouteParams | str | None = None,
    weights: np.ndarray | None = None,
    threads: int | None = None,
    advances: np.ndarray | None = None,
    reference_distances: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
    """:func:`route_filter` with the filter's speed per frame (references per query frame: the
    speed model's mean speed, the odometry model's mean advance; NaN for the window model) and
    the motion model that ran (a name of :data:`~nightloc.route.params.MOTION_MODELS`) appended."""
    p = resolve_params(params)
    if not isinstance(matrix, np.ndarray):
        raise TypeError(f"matrix must be a numpy.ndarray of dtype float32, got {type(matrix).__name__}")
    if matrix.ndim == 2 and matrix.shape[1] == 0:
        raise ValueError(f"matrix must have at least one reference column, got shape {matrix.shape}")
    if (advances is None) != (reference_distances is None):
        raise ValueError(
            "the odometry model needs both advances (one per query) and reference_distances (one per reference)"
        )
    motion = motion_name(p, reference_distances is not None)
    refs, confidence, off_route, speed = _core.route_filter(
        matrix, core_params(p, motion), weights, thread_count(threads), advances, reference_distances
    )
    return refs, confidence, off_route, speed, motion


def motion_name(params: RouteParams, odometry: bool) -> str:
    """The motion model the filter runs: given odometry (the references' distances), one that
    moves by the distance travelled (``params.filter_motion`` when it is one of
    :data:`~nightloc.route.params.DISTANCE_MOTIONS`, else
    :data:`~nightloc.route.params.ODOMETRY_MOTION`); else ``params.filter_motion``, which must then
    not be one."""
    if odometry:
        return params.filter_motion if params.filter_motion in DISTANCE_MOTIONS else ODOMETRY_MOTION
    if params.filter_motion in DISTANCE_MOTIONS:
        raise ValueError(
            f"filter_motion {params.filter_motion!r} needs odometry: the references' distances along the route and "
            "each query's advance (reference_distances= and advances=, or traverses that carry odometry.csv or poses)"
        )
    return params.filter_motion


def core_params(params: RouteParams, motion: str) -> _core.RouteFilterParams:
    """``params`` as the compiled core takes them, running the motion model ``motion``."""
    core = params.core_filter_params()
    core.motion = motion
    return core


@dataclass(frozen=True)
class FilterStep:
    """The filter's answer for one frame.

    Attributes:
        ref: the most probable reference (0-based).
        confidence: belief within ``filter_window`` references of ``ref``, in [0, 1].
        off_route: probability that the frame shows no reference of the route.
        speed: references per frame: the speed model's mean speed, the odometry model's mean
            advance; None for the window model.
    """

    ref: int
    confidence: float
    off_route: float
    speed: float | None = None


class RouteFilter:
    """The filter frame by frame, on difference rows of any origin (e.g. another descriptor's
    distances to the references; lower = more similar).

    Example::

        f = RouteFilter(n_refs=len(refs))
        for row in rows:               # (n_refs,) float32 each
            step = f.step(row)
            step.ref, step.confidence, step.off_route

    Args:
        n_refs: number of references (>= 1).
        params: :class:`RouteParams` or a preset name.
        reference_distances: ``(n_refs,)`` cumulative distance of each reference along the
            route: the odometry model (each :meth:`step` then takes the distance travelled).
    """

    def __init__(
        self, n_refs: int, params: RouteParams | str | None = None, reference_distances: np.ndarray | None = None
    ):
        if isinstance(n_refs, bool) or not isinstance(n_refs, (int, np.integer)) or n_refs < 1:
            raise ValueError(f"n_refs must be a positive int, got {n_refs!r}")
        self._params = resolve_params(params)
        motion = motion_name(self._params, reference_distances is not None)
        self._core = _core.RouteFilter(int(n_refs), core_params(self._params, motion), reference_distances)

    @property
    def motion(self) -> str:
        """The motion model: a name of :data:`~nightloc.route.params.MOTION_MODELS`."""
        return str(self._core.motion)

    @property
    def params(self) -> RouteParams:
        """The parameters in use."""
        return self._params

    @property
    def belief(self) -> np.ndarray:
        """``(n_refs,)`` float64 copy of the on-route belief (sums to ``1 - off_route``)."""
        return self._core.belief

    @property
    def off_route(self) -> float:
        """The off-route probability."""
        return float(self._core.off_route)

    def step(self, row: np.ndarray, weight: float = 1.0, advance: float = 0.0) -> FilterStep:
        """One frame: ``row`` ``(n_refs,)`` float32 differences; ``weight`` in [0, 1] scales the
        evidence (0: prediction only); ``advance``: the odometry model's distance travelled
        since the previous frame (ignored by the other models)."""
        ref, confidence, off, speed = self._core.step(row, float(weight), float(advance))
        return FilterStep(int(ref), float(confidence), float(off), None if math.isnan(speed) else float(speed))

    def run(
        self, rows: np.ndarray, weights: np.ndarray | None = None, advances: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Consecutive frames: ``rows`` ``(n, n_refs)`` float32, optional ``(n,)`` weights and
        (odometry model) advances; returns ``(refs, confidence, off_route)`` arrays, continuing
        from the current state."""
        return self._core.run(rows, weights, 1, advances)[:3]

    def reset(self) -> None:
        """Back to the uniform belief."""
        self._core.reset()

    def set_state(self, belief: np.ndarray, off_route: float = 0.0) -> None:
        """Replaces the state (normalized); e.g. a prior from GPS or from a saved run."""
        self._core.set_state(np.asarray(belief, dtype=np.float64), float(off_route))
