"""Online route localization, one camera frame at a time: the route filter (default) or causal
SeqSLAM.

:class:`RouteLocalizer` holds the prepared reference route. Each :meth:`RouteLocalizer.update`
prepares the new frame and compares it with every reference (one row of the difference matrix,
in the compiled core), enhances that row on its own (the causal offset needs no other frame),
then

* ``method="filter"`` (default): one step of the route filter (:mod:`nightloc.route.filter`) --
  the difference row, its enhancement, the frame's texture weight and the filter step are one
  call into the core; the answer exists from the first frame;
* ``method="seqslam"``: searches the trajectories that *end* at this frame over the enhanced rows
  of the last ``ds`` frames.

Results are bit-identical to the batch computation ``match_prepared(refs, queries, params)`` on
the same frames (with ``mode="causal"`` for SeqSLAM).

Cost per frame: ``n_ref * H * W`` byte comparisons, plus a few passes over ``n_ref`` values
(filter) or ``n_ref * n_speeds * ds`` additions (SeqSLAM); memory: the belief (``n_ref``
doubles) or ``ds`` rows of ``n_ref`` float32 beyond the reference images.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .. import _core
from .._validate import StreamGuard, shift_list, thread_count, uint8_array
from ..io.traverse import Traverse
from ..preparation.params import PreparationParams
from .filter import core_params, motion_name
from .odometry import route_odometry
from .params import DISTANCE_MOTIONS, RouteParams, resolve_params
from .pipeline import TraverseInput, _as_frames, _divisor
from .preparation import RoutePreparer

__all__ = ["RouteLocalizer", "RouteUpdate"]


@dataclass(frozen=True)
class RouteUpdate:
    """The localizer's answer for one frame.

    Attributes:
        index: 0-based position of this frame in the query stream (since the last reset).
        ref: the matched reference (0-based); SeqSLAM: None until ``ds`` frames have been seen.
        score: lower = more confident: ``1 - confidence`` (filter) or the uniqueness ratio
            (SeqSLAM; NaN while ``ref`` is None).
        confidence: filter: belief within ``filter_window`` references of ``ref``; NaN for SeqSLAM.
        off_route: filter: probability that the frame shows no reference; NaN for SeqSLAM.
        speed: filter: references per frame (the speed model's mean speed, the odometry model's
            mean advance); None for the window model and SeqSLAM.
    """

    index: int
    ref: int | None
    score: float
    confidence: float = math.nan
    off_route: float = math.nan
    speed: float | None = None

    @property
    def matched(self) -> bool:
        """True when a match is reported."""
        return self.ref is not None

    def accepted(self, threshold: float) -> bool:
        """True when matched with ``score <= threshold`` (a threshold from :mod:`evaluation`)."""
        return self.ref is not None and not math.isnan(self.score) and self.score <= threshold


class RouteLocalizer:
    """Streaming route localizer: the route filter (default) or causal SeqSLAM.

    Example::

        localizer = nightloc.RouteLocalizer(nightloc.load_traverse("day_route"))
        for frame in camera:
            update = localizer.update(frame)
            if update.confidence > 0.9:
                print(update.index, "->", update.ref)

    Args:
        reference: the reference route: a :class:`~nightloc.Traverse`, a path, frames, or, with
            ``prepared=True``, an ``(N, H, W)`` uint8 stack of prepared images.
        params: :class:`RouteParams` or a preset name; ``mode`` is always ``"causal"`` here.
        preset: a preset name (alternative to ``params``).
        method: ``"filter"`` or ``"seqslam"``, replacing ``params.method``.
        preparation: :class:`PreparationParams` for the ``"nightloc"`` preparation.
        prepared: the reference is already prepared.
        threads: worker threads for each frame (None: all cores).
        channel_order: colour order of the frames given, ``"bgr"`` or ``"rgb"``.
        odometry: run the filter's odometry model: each :meth:`update` then takes the distance
            the robot travelled since the previous frame (``advance``, in the unit of the
            reference's distances). The references' distances along the route are
            ``reference_distances`` or, when that is None, read from the reference traverse's
            ``odometry.csv`` or poses (:mod:`nightloc.route.odometry`).
        reference_distances: ``(N,)`` cumulative distance of each reference along the route
            (implies ``odometry``).

    One localizer is one stream of frames: :meth:`update` or :meth:`reset` called while another
    thread is inside one raises RuntimeError (use one localizer per thread); ``copy.copy`` gives
    an independent localizer in the same state.
    """

    def __init__(
        self,
        reference: TraverseInput,
        params: RouteParams | str | None = None,
        *,
        preset: str | None = None,
        method: str | None = None,
        preparation: PreparationParams | None = None,
        prepared: bool = False,
        threads: int | None = None,
        channel_order: Literal["bgr", "rgb"] = "bgr",
        odometry: bool = False,
        reference_distances: np.ndarray | None = None,
    ):
        if params is not None and preset is not None:
            raise TypeError("give params or preset, not both")
        chosen = resolve_params(preset if preset is not None else params, method=method)
        self._params = dataclasses.replace(chosen, mode="causal")
        self._preparer = RoutePreparer(self._params, preparation, channel_order)
        source: object = reference
        if prepared:
            refs = uint8_array(reference, 3, "reference")
        else:
            frames = _as_frames(reference, "reference", 1)
            source = frames
            refs = self._preparer(frames)
            if refs.ndim != 3:
                raise ValueError("the reference route must hold several frames, not a single image")
        n_refs = refs.shape[0]
        needed = 2 * self._params.uniqueness_radius + 2
        if self._params.method == "seqslam" and n_refs < needed:
            raise ValueError(
                f"the reference route has {n_refs} frames; a uniqueness window of +-{self._params.uniqueness_radius} "
                f"needs at least {needed}"
            )
        if n_refs < 2:
            raise ValueError("the reference route needs at least 2 frames")
        self._refs = np.ascontiguousarray(refs)
        self._shifts = shift_list(self._params.shifts, refs.shape[2])
        self._window_shift = self._params.window_for(refs.shape[1], refs.shape[2])
        self._divisor = _divisor(self._params, self._refs)
        self._threads = thread_count(threads)
        self._seen = 0
        self._guard = StreamGuard("RouteLocalizer")  # one thread at a time (see the class docstring)
        self._row = np.empty((1, n_refs), dtype=np.float32)
        if self._params.method == "filter":
            distances = _reference_distances(source, odometry, reference_distances)
            motion = motion_name(self._params, distances is not None)
            self._filter = _core.RouteFilter(n_refs, core_params(self._params, motion), distances)
            return
        if odometry or reference_distances is not None:
            raise ValueError("odometry is used by the route filter only (method='filter')")
        self._window = np.zeros((self._params.ds, n_refs), dtype=np.float32)

    def __copy__(self) -> RouteLocalizer:
        """An independent localizer in the same state (its own window or belief; the prepared
        references, read-only, are shared)."""
        with self._guard("copy"):
            clone = object.__new__(RouteLocalizer)
            clone.__dict__.update(self.__dict__)
            clone._row = self._row.copy()
            if self._params.method == "filter":
                clone._filter = copy.copy(self._filter)
            else:
                clone._window = self._window.copy()
            clone._guard = StreamGuard("RouteLocalizer")
        return clone

    @property
    def params(self) -> RouteParams:
        """The parameters in use (``mode="causal"``)."""
        return self._params

    @property
    def references(self) -> np.ndarray:
        """``(N, H, W)`` uint8 prepared reference images."""
        return self._refs

    @property
    def motion(self) -> str | None:
        """The filter's motion model (a name of :data:`~nightloc.route.params.MOTION_MODELS`); None
        for SeqSLAM."""
        return str(self._filter.motion) if self._params.method == "filter" else None

    @property
    def frames_seen(self) -> int:
        """Frames given to :meth:`update` since the last :meth:`reset`."""
        return self._seen

    @property
    def belief(self) -> np.ndarray | None:
        """Filter: ``(N,)`` float64 copy of the belief over the references (sums to
        ``1 - off_route``); None for SeqSLAM."""
        return self._filter.belief if self._params.method == "filter" else None

    @property
    def last_row(self) -> np.ndarray:
        """``(N,)`` float32 enhanced difference row of the last frame (a view, overwritten by the
        next update)."""
        return self._row[0] if self._params.method == "filter" else self._window[-1]

    def reset(self) -> None:
        """Forgets the frames seen (e.g. after the robot was moved): the filter's belief becomes
        uniform again."""
        with self._guard("reset"):
            self._seen = 0
            if self._params.method == "filter":
                self._filter.reset()
            else:
                self._window.fill(0.0)

    def prepare(self, frame: np.ndarray) -> np.ndarray:
        """The prepared ``(H, W)`` uint8 image of one camera frame."""
        return self._preparer(frame)

    def update(self, frame: np.ndarray, prepared: bool = False, advance: float | None = None) -> RouteUpdate:
        """Adds one frame; returns its match (filter: from the first frame; SeqSLAM: once ``ds``
        frames exist).

        Args:
            frame: a camera frame (grey ``(H, W)`` or BGR ``(H, W, 3)``), or with
                ``prepared=True`` an ``(H, W)`` uint8 image prepared like the references.
            advance: the odometry model's distance travelled since the previous frame (needed
                from the second frame on; negative: backwards; ignored on the first); must be
                None for the other models.
        """
        with self._guard("update"):
            return self._update(frame, prepared, advance)

    def _check_advance(self, advance: float | None) -> float:
        if self.motion not in DISTANCE_MOTIONS:
            if advance is not None:
                raise ValueError(
                    "advance is for the odometry model; create the localizer with odometry=True "
                    "(or reference_distances) to use it"
                )
            return 0.0
        if advance is None:
            if self._seen == 0:
                return 0.0
            raise ValueError("this localizer runs the odometry model: pass advance= (distance since the last frame)")
        value = float(advance)
        if not math.isfinite(value):
            raise ValueError(f"advance must be a finite distance, got {advance!r}")
        return value

    def _update(self, frame: np.ndarray, prepared: bool, advance: float | None) -> RouteUpdate:
        image = uint8_array(frame, 2, "frame") if prepared else self.prepare(frame)
        if image.ndim != 2:
            raise ValueError(f"update takes one frame, got a stack of {image.shape[0]} frames; loop over them")
        if image.shape != self._refs.shape[1:]:
            raise ValueError(
                f"the prepared frame is {image.shape[0]}x{image.shape[1]} but the references are "
                f"{self._refs.shape[1]}x{self._refs.shape[2]} (height x width)"
            )
        p = self._params
        travelled = self._check_advance(advance)
        if p.method == "filter":
            ref, confidence, off_route, _, speed = self._filter.frame(
                np.ascontiguousarray(image),
                self._refs,
                self._shifts,
                self._divisor,
                p.enhance_radius,
                p.filter_min_texture,
                self._threads,
                self._row,
                self._window_shift,
                travelled,
            )
            index = self._seen
            self._seen += 1
            speed_or_none = None if math.isnan(speed) else float(speed)
            return RouteUpdate(index, int(ref), 1.0 - confidence, confidence, off_route, speed_or_none)
        _core.difference_matrix_into(
            np.ascontiguousarray(image)[np.newaxis],
            self._refs,
            self._shifts,
            self._threads,
            self._divisor,
            self._row,
            self._window_shift,
        )
        # Oldest row first: shift the window up by one and enhance the new row into the last slot.
        self._window[:-1] = self._window[1:]
        _core.enhance_contrast(self._row, p.enhance_radius, "bound", 1, self._window[-1:])
        index = self._seen
        self._seen += 1
        if self._seen < p.ds:
            return RouteUpdate(index=index, ref=None, score=math.nan)
        refs, scores = _core.trajectory_search(
            self._window, p.ds, p.vmin, p.vmax, p.uniqueness_radius, True, p.ds - 1, p.ds, self._threads
        )
        return RouteUpdate(index=index, ref=int(refs[p.ds - 1]), score=float(scores[p.ds - 1]))


def _reference_distances(reference: object, odometry: bool, given: np.ndarray | None) -> np.ndarray | None:
    """The references' distances for the odometry model: ``given``, or with ``odometry`` the
    reference traverse's own (a Traverse or a path), or None (no odometry model)."""
    if given is not None:
        distances = np.asarray(given, dtype=np.float64)
        if distances.ndim != 1:
            raise ValueError(
                f"reference_distances must be a 1-D array (one per reference), got shape {distances.shape}"
            )
        return distances
    if not odometry:
        return None
    if not isinstance(reference, Traverse):
        raise ValueError(
            "odometry=True needs the reference as a traverse (folder, video or Traverse) with odometry.csv or poses, "
            "or reference_distances"
        )
    record = route_odometry(reference)
    if record is None:
        raise ValueError(
            f"the reference traverse {reference.root} has no odometry.csv or poses; pass reference_distances"
        )
    return record.distances
