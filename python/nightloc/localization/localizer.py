"""The streaming 2D localizer: camera frame + odometry in, position, heading and uncertainty out.

::

    ref_map = nightloc.ReferenceMap.load("garden.npz")
    loc = nightloc.Localizer(ref_map, odometry_noise=1)   # the grid Bayes filter (default)
    for frame, motion in camera_and_odometry():
        est = loc.update(frame, nightloc.RobotMotion(forward, left, turn))   # or (dx, dy) in the map frame
        print(est.x, est.y, est.heading, est.credible_radius, est.confidence)

Two methods (docs/localization.md):

* ``method="filter"`` (default): the recursive grid Bayes filter over position x heading of
  :mod:`nightloc.localization.grid_filter`: it predicts by the odometry with its noise
  (``odometry_noise``: a Table III model number or a :class:`NoiseModel`), updates by the frame's
  whole rotational SAD table, and reports position, heading, ``covariance``,
  ``credible_radius`` and ``confidence`` (the belief within ``confidence_radius`` metres: low
  means lost). One call into the compiled core per frame.
* ``method="paper"``: Mount & Milford's 2D sequence matching, reproduced unchanged: each frame
  (docs/design.md steps 2-6) is prepared with the map's parameters, matched against every
  reference at every rotation (eqs. 2-3), turned into a heat map over the grid
  (:mod:`nightloc.localization.heatmap`, eq. 4) and summed with the heat maps of the previous
  ``seq_len - 1`` frames, each translated by the odometry displacement since
  (:mod:`nightloc.localization.sequence`); the estimate is the hottest cell, the heading the
  closest reference's heading plus its rotational match (NaN without map headings). A
  :class:`RobotMotion` is rotated into the map frame with that heading estimate; ``None`` means
  the motion is unknown: the sequence restarts from this frame.

Odometry is the motion since the previous update (:mod:`nightloc.motion.odometry`): a
map-frame ``(dx, dy)`` / :class:`MapDisplacement` or a robot-frame :class:`RobotMotion`; it is
ignored on the first frame (and after :meth:`Localizer.reset`).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from .. import _core
from .._validate import (
    MAX_COORDINATE_M,
    MAX_GRID_CELLS,
    MAX_SEQUENCE_CELLS,
    StreamGuard,
    metres,
    same_image_size,
    thread_count,
    uint8_array,
)
from ..config import params_section
from ..mapping.reference_map import ReferenceMap
from ..matching.sad import MatchResult, match, rotational_sad, shift_table
from ..motion.odometry import Motion, NoiseModel, RobotMotion, as_motion, robot_steps_to_map, wrap_angle
from ..schema import Range, own_field
from .day_scale import learned_mask, learned_proxies, on_day_scale
from .grid_filter import (
    GRID_FILTER_SETTINGS,
    MOTION_NONE,
    FilterParams,
    FilterState,
    GridFilter,
    MotionCode,
    motion_code,
)
from .heatmap import HeatMapper
from .sequence import cumulative_offsets

__all__ = ["METHODS", "Estimate", "LocalizationParams", "Localizer"]

_NO_OFFSETS = np.zeros((0, 2))

#: Longest sequence accepted (memory: one float32 map per frame, 40 KB for 100 x 100 cells).
MAX_SEQ_LEN = 1000


@params_section("localization")
@dataclass(frozen=True)
class LocalizationParams:
    """How heat maps and sequences are built (paper Table II and section III; TOML ``[localization]``).

    Attributes:
        grid_width, grid_height: heat-map cells along x and y (the paper's 100 x 100).
        margin: metres between the outermost references and the outermost cell centres.
        seq_len: frames per sequence, n (the paper: 1-10; its headline figures use 7); only for
            ``method="paper"``.
        interpolation: linear interpolation of scores between references (True) or the nearest
            reference (False; the estimate is then a reference position, the paper's comparison).
        outside: value of cells outside the reference hull: ``"lowest"`` (the frame's lowest
            heat: never preferred) or ``"nearest"`` (their nearest reference's).
        inversion: scores to heat, see :func:`nightloc.localization.heatmap.invert_scores` (``"range"``:
            best 1, worst 0 per frame, so each frame weighs the same in a sequence); the paper's
            method only (the filter turns scores into likelihoods).
        confidence_radius: metres: the paper's method ignores the cells this close to the peak
            when finding the second-best place; the filter's confidence is the belief within it.
    """

    grid_width: int = own_field(100, unit="cells", range=Range(2, math.inf))
    grid_height: int = own_field(100, unit="cells", range=Range(2, math.inf))
    margin: float = own_field(0.25, unit="m", range=Range(0, MAX_COORDINATE_M, max_open=True))
    seq_len: int = own_field(7, unit="frames", range=Range(1, MAX_SEQ_LEN))
    interpolation: bool = True
    outside: Literal["lowest", "nearest"] = "lowest"
    inversion: Literal["range", "zscore", "negate"] = "range"
    confidence_radius: float = GRID_FILTER_SETTINGS.field("confidence_radius")

    def validate(self) -> None:
        """The rules between fields (each field's range is checked on construction, from the
        table): the grid's and the sequence's size, and the radius below MAX_COORDINATE_M (the
        core's table bounds it by 0 only)."""
        metres(self.confidence_radius, "confidence_radius", minimum=0.0)
        if self.grid_width * self.grid_height > MAX_GRID_CELLS:
            raise ValueError(
                f"grid of {self.grid_width}x{self.grid_height} cells is too large (at most {MAX_GRID_CELLS} cells, "
                f"MAX_GRID_CELLS)"
            )
        cells = self.seq_len * self.grid_height * (self.grid_width + 1)  # the sequence's padded float32 maps
        if cells > MAX_SEQUENCE_CELLS:
            raise ValueError(
                f"seq_len {self.seq_len} over a {self.grid_width}x{self.grid_height} grid needs {cells} float32 "
                f"cells, more than {MAX_SEQUENCE_CELLS} (MAX_SEQUENCE_CELLS, 512 MiB); shorten the sequence or "
                f"coarsen the grid"
            )


@dataclass(frozen=True)
class Estimate:
    """One localizer update's answer.

    Attributes:
        x, y: position estimate, metres in the map frame.
        heading: radians in (-pi, pi], or NaN when the map has no headings.
        ref_index: the reference closest to the estimate.
        confidence: 0..1. The filter: the belief within ``confidence_radius`` metres of the
            estimate (low = lost). The paper's method: how much the peak stands out
            (:class:`nightloc.localization.heatmap.HeatEstimate`).
        frames: frames fused: the paper's method 1 .. seq_len; the filter, frames since the start
            (or :meth:`Localizer.reset`).
        best_ref: the single frame's best match (lowest score), and ``score`` its score (-1 and
            NaN after a prediction without a frame).
        heatmap: ``(grid_height, grid_width)`` (row 0 = lowest y), when asked: the paper's fused
            heat map, or the filter's belief over position (summed over heading, sums to 1).
        frame_heatmap: this frame's own heat map (inverted scores), when asked.
        covariance: ``((xx, xy), (xy, yy))`` m^2, the filter's belief about its mean (a tuple, so
            that estimates compare with ``==``; ``numpy.asarray`` makes it an array), None for the
            paper's method.
        credible_radius: metres around ``(x, y)`` holding ``credibility`` (default 0.9) of the
            filter's belief (NaN for the paper's method).
        method: ``"filter"`` or ``"paper"``.
        heading_variance: rad^2, the filter's belief about its heading (its heading histogram about
            the circular mean, at most pi^2); NaN while the belief is position-only and for the
            paper's method.
    """

    x: float
    y: float
    heading: float
    ref_index: int
    confidence: float
    frames: int
    best_ref: int
    score: float
    heatmap: np.ndarray | None = None
    frame_heatmap: np.ndarray | None = None
    covariance: tuple[tuple[float, float], tuple[float, float]] | None = None
    credible_radius: float = math.nan
    method: str = "paper"
    heading_variance: float = math.nan

    @property
    def position(self) -> np.ndarray:
        """``(2,)`` the estimate ``[x, y]`` in metres."""
        return np.array([self.x, self.y])


#: Localization methods: the grid Bayes filter (default) and the paper's n-frame sum.
METHODS = ("filter", "paper")


class Localizer:
    """Streaming 2D localization against a reference map.

    Args:
        ref_map: the :class:`~nightloc.ReferenceMap` (prepared day images with poses).
        params: :class:`LocalizationParams` (grid, margin, interpolation, ...); None (default):
            the map's (:attr:`~nightloc.ReferenceMap.settings`, what ``nightloc build-map --params``
            stored; a map without: the paper's values).
        method: ``"filter"`` (default, the grid Bayes filter) or ``"paper"`` (the paper's sum of
            the last ``seq_len`` heat maps, unchanged).
        odometry_noise: the filter's odometry noise per frame: a Table III model number (0-3) or
            a :class:`NoiseModel` (metres on the step length, radians on the turn or step
            direction). Default 1 (0.1 m, 0.02 rad).
        filter_params: :class:`~nightloc.localization.grid_filter.FilterParams` of the filter;
            None (default): the map's, as ``params``.
        threads: matching threads (default 1: one core per frame, the robot's budget).
        **overrides: fields of ``params`` or ``filter_params`` to replace, e.g.
            ``grid_width=80, likelihood_gain=2.5``; ``seq_len`` only with ``method="paper"``.

    The grid, triangulation and interpolation weights are computed here, once.

    **The map's settings.** A map keeps the ``[localization]`` and ``[filter]`` settings it was
    built with (``nightloc build-map --params``), and its file carries the filter's tables made
    with them. ``Localizer(ref_map)`` runs those settings, as ``nightloc localize``, the ROS 2 node
    and the firmware (``nightloc_replay``) do: one filter on one map. A ``params`` or
    ``filter_params`` given replaces the map's section as a whole (a ``FilterParams()`` is the
    defaults, whatever the map says); ``**overrides`` change single fields of the map's (or the
    given) settings.

    A localizer is one stream of frames: :meth:`update` from two threads at once raises
    RuntimeError (the order of the frames would be a race); use one localizer per thread (they
    may share the map). ``copy.copy`` gives an independent localizer with the same state that
    shares the map and the grid; ``copy.deepcopy`` copies those too.
    """

    def __init__(
        self,
        ref_map: ReferenceMap,
        params: LocalizationParams | None = None,
        *,
        method: str = "filter",
        odometry_noise: int | NoiseModel = 1,
        filter_params: FilterParams | None = None,
        threads: int = 1,
        **overrides: Any,
    ):
        if not isinstance(ref_map, ReferenceMap):
            raise TypeError(f"ref_map must be a nightloc.ReferenceMap, got {type(ref_map).__name__}")
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        stored = ref_map.settings  # the settings the map was built with (checked when it was made)
        params = LocalizationParams(**stored.get("localization", {})) if params is None else params
        if not isinstance(params, LocalizationParams):
            raise TypeError(f"params must be a LocalizationParams, got {type(params).__name__}")
        filter_params = FilterParams(**stored.get("filter", {})) if filter_params is None else filter_params
        if not isinstance(filter_params, FilterParams):
            raise TypeError(f"filter_params must be a FilterParams, got {type(filter_params).__name__}")
        if overrides:
            loc_names = {f.name for f in dataclasses.fields(LocalizationParams)}
            filter_names = {f.name for f in dataclasses.fields(FilterParams)}
            unknown = sorted(set(overrides) - loc_names - filter_names)
            if unknown:
                raise TypeError(
                    f"unknown localization parameter(s) {unknown}; known: {sorted(loc_names | filter_names)}"
                )
            if "seq_len" in overrides and method != "paper":
                raise ValueError(
                    "seq_len is the paper's sequence length: pass method='paper' to sum the last seq_len heat maps "
                    "(the default method, the Bayes filter, uses every frame and has no sequence length)"
                )
            params = dataclasses.replace(params, **{k: v for k, v in overrides.items() if k in loc_names})
            filter_params = dataclasses.replace(
                filter_params, **{k: v for k, v in overrides.items() if k in filter_names}
            )
        self.ref_map = ref_map
        self.method = method
        self.params = params
        self.filter_params = filter_params
        self.threads = thread_count(threads)  # checked here, not at the first frame
        self.mapper = HeatMapper(
            ref_map.positions,
            grid_width=params.grid_width,
            grid_height=params.grid_height,
            margin=params.margin,
            interpolation=params.interpolation,
            outside=params.outside,
            inversion=params.inversion,
            confidence_radius=params.confidence_radius,
        )
        self._shifts = ref_map.params.shifts
        self._learned = learned_mask(ref_map)  # experience maps: learned looks as evidence about day images
        self._proxies = (
            None
            if self._learned is None
            else learned_proxies(self._learned, self.mapper.place_of_ref, ref_map.headings)
        )
        self._prepared_shape = (ref_map.params.height, ref_map.params.width)
        if method == "filter":
            self._filter: GridFilter | None = self._new_filter(odometry_noise)
            self._sequence = None
        else:
            self._filter = None
            self._sequence = self.mapper.sequence(params.seq_len)
        self._guard = StreamGuard("Localizer")  # one thread at a time (see the class docstring)
        self._revision = 0
        self.reset()

    def __copy__(self) -> Localizer:
        with self._guard("copy"):
            clone = object.__new__(Localizer)
            clone.__dict__.update(self.__dict__)
            if self._filter is not None:
                clone._filter = copy.copy(self._filter)  # the belief: not shared
            else:
                clone._sequence = copy.deepcopy(self._sequence)  # the frames' heat maps: not shared
                clone._motions = deque(self._motions, maxlen=self._motions.maxlen)
            clone._guard = StreamGuard("Localizer")
        return clone

    def fresh(self) -> Localizer:
        """A new localizer for the same map, method and parameters, sharing this one's grid and
        interpolation weights (no recomputation), with nothing seen yet: e.g. one per robot or
        thread over one map."""
        clone = object.__new__(Localizer)
        clone.__dict__.update(self.__dict__)
        if self._filter is not None:
            clone._filter = self._new_filter(self._filter.noise)
        else:
            clone._sequence = self.mapper.sequence(self.params.seq_len)
        clone._guard = StreamGuard("Localizer")
        clone.reset()
        return clone

    def _new_filter(self, noise: int | NoiseModel) -> GridFilter:
        """A compiled filter over this localizer's grid, with nothing seen yet."""
        return GridFilter(
            self.mapper,
            self.ref_map.headings,
            self.ref_map.params.width,
            self._shifts,
            self.filter_params,
            noise,
            self.params.confidence_radius,
            self._learned,
        )

    def with_seq_len(self, seq_len: int) -> Localizer:
        """A new localizer for the same map and parameters but another sequence length.

        It shares this one's grid and interpolation weights (no recomputation) and starts with
        an empty sequence; useful to evaluate several sequence lengths. The paper's method only.
        """
        if self.method != "paper":
            raise ValueError("with_seq_len is for method='paper' (the filter has no sequence length)")
        params = dataclasses.replace(self.params, seq_len=seq_len)
        clone = object.__new__(Localizer)
        clone.__dict__.update(self.__dict__)
        clone.params = params
        clone._sequence = self.mapper.sequence(params.seq_len)
        clone._guard = StreamGuard("Localizer")
        clone.reset()
        return clone

    @property
    def grid(self):
        """The heat-map :class:`~nightloc.localization.heatmap.HeatGrid`."""
        return self.mapper.grid

    @property
    def grid_filter(self) -> GridFilter:
        """The compiled :class:`~nightloc.localization.grid_filter.GridFilter` this localizer drives
        (``method="filter"``): its ``settings`` are what the core was given."""
        return self._require_filter("grid_filter")

    @property
    def heading(self) -> float:
        """The current heading estimate (radians, NaN if unknown)."""
        return self._heading

    @property
    def revision(self) -> int:
        """A count that changes whenever the state changes (a frame, a prediction, a reset, a set
        pose or belief; not a new noise model): a caller that drives this localizer can tell
        whether someone else moved it between two of its calls."""
        return self._revision

    @property
    def noise(self) -> NoiseModel:
        """The filter's odometry noise model (the paper's method does not use one)."""
        return self._require_filter("noise").noise

    @noise.setter
    def noise(self, value: int | NoiseModel) -> None:
        self._require_filter("noise").set_noise(value)

    @property
    def belief(self) -> np.ndarray:
        """The filter's belief over position, ``(grid_height, grid_width)`` float64 summing to 1
        (summed over heading); row 0 is the lowest y, see :attr:`grid`."""
        return self._require_filter("belief").marginal()

    @property
    def pose_belief(self) -> np.ndarray:
        """The filter's whole belief ``(bins, grid_height, grid_width)`` float64 (one bin while it
        is position-only); bin b is centred on heading ``heading_offset + 2 pi b / bins``."""
        return self._require_filter("pose_belief").belief()

    @property
    def heading_offset(self) -> float:
        """Radians: the centre of the filter's heading bin 0."""
        return self._require_filter("heading_offset").offset

    def _require_sequence(self) -> _core.HeatSequence:
        if self._sequence is None:  # the filter has none; the paper's method always has one
            raise RuntimeError("internal error: the paper's method without its heat-map sequence")
        return self._sequence

    def _require_filter(self, what: str) -> GridFilter:
        if self._filter is None:
            raise AttributeError(
                f"{what} is the Bayes filter's (method='filter'); this localizer runs the paper's method"
            )
        return self._filter

    def reset(self) -> None:
        """Forgets everything seen (e.g. after the robot was carried elsewhere): the paper's
        sequence, or the filter's belief (uniform again); and the heading."""
        with self._guard("reset"):
            self._reset()

    def _reset(self) -> None:
        self._revision += 1
        self._heading = math.nan
        self._frames = 0
        if self._filter is not None:
            self._filter.reset()
            return
        self._require_sequence().clear()  # the frames' excess heat maps and fill values (in the core)
        self._motions: deque[Motion] = deque(maxlen=max(self.params.seq_len - 1, 1))

    def set_pose(self, x: float, y: float, heading: float = math.nan, covariance: np.ndarray | None = None) -> None:
        """The filter's belief becomes a Gaussian about ``(x, y)`` metres and ``heading`` radians
        (what RViz's "2D Pose Estimate" sends): ``covariance`` ``(3, 3)`` of x, y and heading (m^2,
        rad^2; default 0.25 m and 0.2 rad standard deviations), widened by half a cell and half a
        heading bin. A NaN heading or heading variance, or a filter without heading bins: the
        heading stays unknown (uniform). ValueError when the pose lies too far off the grid for
        any cell to hold belief."""
        flt = self._require_filter("set_pose")
        cov = np.diag([0.0625, 0.0625, 0.04]) if covariance is None else np.asarray(covariance, dtype=np.float64)
        if cov.shape != (3, 3) or not np.isfinite(cov[:2, :2]).all() or not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"set_pose needs a finite x, y and a (3, 3) covariance, got {x}, {y}, shape {cov.shape}")
        grid = self.grid
        position_cov = cov[:2, :2] + np.diag([(grid.dx / 2) ** 2, (grid.dy / 2) ** 2])
        try:
            inverse = np.linalg.inv(position_cov)
        except np.linalg.LinAlgError:
            raise ValueError(f"set_pose: the position covariance {cov[:2, :2].tolist()} is singular") from None
        gx, gy = np.meshgrid(np.asarray(grid.xs) - x, np.asarray(grid.ys) - y)
        distance2 = inverse[0, 0] * gx * gx + 2 * inverse[0, 1] * gx * gy + inverse[1, 1] * gy * gy
        position = np.exp(-0.5 * distance2)
        if not position.sum() > 0:
            raise ValueError(f"set_pose: ({x:g}, {y:g}) lies off the map's grid ({grid.x0:g}.. m, {grid.y0:g}.. m)")
        heading_var = float(cov[2, 2])
        if flt.can_pose:
            bins = int(flt.settings.heading_bins)
            step = 2 * math.pi / bins
            if math.isfinite(heading) and math.isfinite(heading_var) and heading_var >= 0:
                offset = np.asarray(wrap_angle(step * np.arange(bins) - heading))
                weights = np.exp(-0.5 * offset**2 / (heading_var + (step / 2) ** 2))
            else:
                weights = np.ones(bins)
            belief = weights[:, None, None] * position[None]
            pose = True
        else:
            belief, pose = position[None], False
        with self._guard("set_pose"):
            self._revision += 1
            flt.core.set_belief(np.ascontiguousarray(belief / belief.sum(), dtype=np.float32), pose, 0.0)
            self._heading = float(wrap_angle(heading)) if math.isfinite(heading) else math.nan

    def update(
        self,
        frame: np.ndarray,
        odometry: object = None,
        *,
        prepared: bool | None = None,
        return_heatmap: bool = False,
    ) -> Estimate:
        """Localizes one camera frame.

        Args:
            frame: a raw camera frame (grey or BGR, uint8/uint16, any size: prepared with the
                map's parameters), or a prepared ``(Ry, Rx)`` uint8 image.
            odometry: motion since the previous update: ``(dx, dy)`` / :class:`MapDisplacement`
                (map frame, metres) or :class:`RobotMotion`; None = unknown (restarts the
                sequence; ignored on the first frame).
            prepared: whether ``frame`` is already prepared; None decides by shape (a uint8
                ``(Ry, Rx)`` array is taken as prepared).
            return_heatmap: include the fused and the frame's heat maps in the estimate.
        """
        if prepared is None:
            prepared = isinstance(frame, np.ndarray) and frame.dtype == np.uint8 and frame.shape == self._prepared_shape
        query = frame if prepared else self.ref_map.preparer.prepare(frame)
        if isinstance(query, np.ndarray) and query.ndim != 2:
            raise ValueError(f"update takes one frame, got an array of shape {query.shape}; loop over its frames")
        if self._filter is not None:
            query = uint8_array(query, 2, "frame")
            same_image_size(query, self.ref_map.images, "the prepared frame's", "the map's")
            with self._guard("update"):
                motion = self._motion(odometry)
                state = self._filter.step_image(query, self.ref_map.images, motion, self.threads)
                return self._filter_estimate(state, return_heatmap)
        result = match(query, self.ref_map.images, shifts=self._shifts, threads=self.threads)
        return self.update_match(result, odometry, return_heatmap=return_heatmap)

    def score_table(self, frame: np.ndarray, *, prepared: bool | None = None) -> np.ndarray:
        """The filter's measurement of one frame: ``(N, columns)`` float32, what :meth:`update_table`
        takes (:func:`nightloc.rotational_sad` against the map with its shifts, or with the
        filter's translation window, ``shift_table(..., shift_window=...).scores``: a forward
        camera's column offsets, ``row_window``)."""
        flt = self._require_filter("score_table")
        if prepared is None:
            prepared = isinstance(frame, np.ndarray) and frame.dtype == np.uint8 and frame.shape == self._prepared_shape
        query = uint8_array(frame if prepared else self.ref_map.preparer.prepare(frame), 2, "frame")
        same_image_size(query, self.ref_map.images, "the prepared frame's", "the map's")
        if flt.window == (0, 0):
            return rotational_sad(query, self.ref_map.images, shifts=flt.shifts, threads=self.threads)
        return shift_table(query, self.ref_map.images, flt.shifts, self.threads, flt.window).scores

    def update_table(self, table: np.ndarray, odometry: object = None, *, return_heatmap: bool = False) -> Estimate:
        """The filter's :meth:`update` from the frame's whole rotational SAD table, ``(N, columns)``
        float32 (:meth:`score_table`: :func:`nightloc.rotational_sad` of the prepared frame against
        the map, with the map's shifts, or with the filter's translation window): the measurement
        the filter uses. NaN or infinity: ValueError, the belief unchanged."""
        flt = self._require_filter("update_table")
        t = self._checked_table(flt, table)
        with self._guard("update"):
            motion = self._motion(odometry)
            state = flt.step_table(t, motion)
            return self._filter_estimate(state, return_heatmap)

    def update_table_with_prior(self, table: np.ndarray, odometry: object = None) -> tuple[Estimate, np.ndarray]:
        """:meth:`update_table`, and the prior it measured: the belief over position predicted to
        this frame before its table, ``(grid_height, grid_width)`` float64 summing to 1 (the belief
        as it was on the first frame since a reset). The same as :meth:`predict` on a copy, its
        :attr:`belief`, then :meth:`update_table` here, bit for bit, with the belief moved once:
        e.g. a backward run's predictions for a two-filter smoother."""
        flt = self._require_filter("update_table_with_prior")
        t = self._checked_table(flt, table)
        with self._guard("update"):
            motion = self._motion(odometry)
            state, prior = flt.step_table_with_prior(t, motion)
            return self._filter_estimate(state, False), prior

    def _checked_table(self, flt: GridFilter, table: np.ndarray) -> np.ndarray:
        """``table`` as the core takes it, checked: float32 ``(N, columns)`` of this map."""
        t = np.asarray(table)
        if t.dtype != np.float32:
            raise TypeError(f"table must have dtype float32 (as rotational_sad returns), got {t.dtype}")
        shape = (len(self.ref_map), len(flt.columns))
        if t.shape != shape:
            what = "column offsets" if flt.window[0] else "shifts"
            raise ValueError(f"table must be {shape} (references, {what}), got shape {t.shape}")
        return np.ascontiguousarray(t)

    def predict(self, odometry: object = None, *, return_heatmap: bool = False) -> Estimate:
        """The filter's prediction alone: the robot moved by ``odometry`` (None: unknown) but there
        is no usable frame; the belief moves and spreads. ``best_ref`` is -1 and ``score`` NaN."""
        flt = self._require_filter("predict")
        motion = self._checked_motion(as_motion(odometry))
        with self._guard("predict"):
            state = flt.predict(motion_code(motion))
            return self._filter_estimate(state, return_heatmap, frame=False)

    def estimate_belief(self, belief: np.ndarray) -> Estimate:
        """Replaces the filter's belief by the position belief ``belief`` ``(grid_height,
        grid_width)`` (non-negative, any positive sum; the heading forgotten) and returns its
        estimate as :meth:`predict` reports one (``best_ref`` -1, ``score`` NaN): e.g. of the
        product of a forward and a backward run's beliefs (a smoother)."""
        flt = self._require_filter("estimate_belief")
        b = np.asarray(belief, dtype=np.float64)
        if b.shape != self.mapper.grid.shape:
            raise ValueError(f"belief must be {self.mapper.grid.shape} (grid_height, grid_width), got shape {b.shape}")
        total = float(b.sum())
        if not (np.all(np.isfinite(b)) and np.all(b >= 0) and total > 0):
            raise ValueError("belief must be finite, non-negative and not all zero")
        with self._guard("estimate_belief"):
            state = flt.estimate_belief(np.ascontiguousarray(b / total, dtype=np.float32))
            return self._filter_estimate(state, False, frame=False)

    def _motion(self, odometry: object) -> MotionCode:
        motion = as_motion(odometry)
        if self._frames == 0:
            return (MOTION_NONE, 0.0, 0.0, 0.0)  # the first frame: nothing to move yet
        return motion_code(self._checked_motion(motion))

    def _checked_motion(self, motion: Motion | None) -> Motion | None:
        if isinstance(motion, RobotMotion) and not self._require_filter("robot-frame odometry").can_pose:
            raise ValueError(
                "robot-frame odometry (RobotMotion) needs heading bins, and this filter has none: the reference map "
                "has no headings (or its images are not 360-degree panoramas); pass map-frame displacements "
                "(MapDisplacement or (dx, dy)) instead"
            )
        return motion

    def _filter_estimate(self, state: FilterState, return_heatmap: bool, frame: bool = True) -> Estimate:
        self._frames += int(frame)
        self._revision += 1
        headings = self.ref_map.headings
        scores = state.scores
        cell = self.mapper._cell_of(state.x, state.y)
        ref = self.mapper.closest_ref(cell, scores)
        heading = state.heading
        if not math.isfinite(heading):
            shifts = state.shifts  # None with scores: a prediction without a frame
            if headings is not None and scores is not None and shifts is not None:
                # position-only: the closest reference's match
                width = self.ref_map.params.width
                flt = self._require_filter("heading")
                turn = float(shifts[ref]) * (flt.field_of_view if flt.window[0] else 2.0 * math.pi) / width
                heading = float(wrap_angle(float(headings[ref]) + turn))
            else:
                heading = self._heading if scores is None else math.nan
        self._heading = heading
        best = int(np.argmin(scores)) if scores is not None else -1
        cov = state.covariance
        return Estimate(
            x=state.x,
            y=state.y,
            heading=heading,
            ref_index=ref,
            confidence=state.confidence,
            frames=self._frames,
            best_ref=best,
            score=float(scores[best]) if scores is not None else math.nan,
            heatmap=self._require_filter("heatmap").marginal() if return_heatmap else None,
            frame_heatmap=self.mapper.heat_map(scores)[0] if return_heatmap and scores is not None else None,
            covariance=((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1]))),
            credible_radius=state.credible_radius,
            method="filter",
            heading_variance=state.heading_variance,
        )

    def update_match(self, result: MatchResult, odometry: object = None, *, return_heatmap: bool = False) -> Estimate:
        """Like :meth:`update`, from a frame already matched against the map (a MatchResult).

        The paper's method only: the filter's measurement is the whole rotational table, which a
        MatchResult does not hold; use :meth:`update_table` (or :meth:`update`) with the filter.
        """
        if self._filter is not None:
            raise TypeError(
                "the Bayes filter needs the frame's whole rotational SAD table, not a MatchResult (its minimum per "
                "reference): call update(frame) or update_table(nightloc.rotational_sad(prepared, ref_map.images)), "
                "or use method='paper'"
            )
        with self._guard("update"):
            return self._update_match(result, odometry, return_heatmap)

    def _update_match(self, result: MatchResult, odometry: object, return_heatmap: bool) -> Estimate:
        if not isinstance(result, MatchResult):
            raise TypeError(f"result must be a nightloc.MatchResult, got {type(result).__name__}")
        if result.scores.shape != (len(self.ref_map),):
            raise ValueError(
                f"result has {result.scores.shape[0]} scores but the map has {len(self.ref_map)} references"
            )
        sequence = self._require_sequence()
        motion = as_motion(odometry)
        headings = self.ref_map.headings
        stored = sequence.size
        if isinstance(motion, RobotMotion) and headings is None and stored:
            raise ValueError(
                "robot-frame odometry (RobotMotion) needs a heading estimate, and there is none: the reference "
                "map has no headings; pass map-frame displacements (MapDisplacement or (dx, dy)) instead"
            )
        scores = on_day_scale(result.scores, self._learned, self._proxies)  # learned looks: evidence
        values, fill = self.mapper.place_excess(scores)  # checks the scores before any state changes
        if isinstance(motion, RobotMotion) and math.isfinite(self._heading):
            predicted = self._heading + motion.turn
        elif headings is not None:
            predicted = float(headings[result.index] + result.headings[result.index])
        else:
            predicted = math.nan
        # frames fused with this one: none when the motion is unknown (a restart of the sequence)
        earlier = 0 if motion is None else min(stored, self.params.seq_len - 1)
        if earlier and motion is not None:
            motions = ([*list(self._motions), motion])[-earlier:]
            steps = robot_steps_to_map(motions, predicted)
            offsets = np.ascontiguousarray(self.grid.to_cells(cumulative_offsets(steps)))
            if not np.isfinite(offsets).all():
                raise ValueError(f"odometry gives non-finite displacements: {offsets.tolist()}")
        else:
            offsets = _NO_OFFSETS
        # the update is valid: change the state
        self._revision += 1
        if motion is None:
            if stored:  # restart
                sequence.clear()
                self._motions.clear()
        elif stored:
            self._motions.append(motion)
        sequence.push(values, fill)
        fill_sum, cell, peak, floor, second = sequence.fuse_peak(offsets)
        heatmap = sequence.fused() + fill_sum if return_heatmap else None
        frame_heatmap = sequence.frame(-1) + fill if return_heatmap else None
        found = self.mapper.estimate_from_peak(cell, peak, floor, second, scores)
        if headings is not None:
            self._heading = float(wrap_angle(headings[found.ref_index] + result.headings[found.ref_index]))
        return Estimate(
            x=found.x,
            y=found.y,
            heading=self._heading,
            ref_index=found.ref_index,
            confidence=found.confidence,
            frames=earlier + 1,
            best_ref=int(result.index),
            score=float(result.score),
            heatmap=heatmap,
            frame_heatmap=frame_heatmap,
        )
