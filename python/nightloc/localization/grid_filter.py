"""The recursive grid Bayes filter over position x heading: the robot's localizer.

The paper's 2D method sums the heat maps of the last n frames shifted by odometry: it trusts
the odometry completely and cannot say when it is lost. This filter (histogram filter, Markov
localization; docs/localization.md) keeps a belief over the heat-map grid **x heading bins**
(by default one bin per panorama column, so a column shift is a heading bin) and, per frame:

1. **predicts** by the odometry: each heading slice moves by the robot-frame motion rotated by
   its own heading (sub-cell), the heading axis turns by the motion's turn (exactly: whole bins
   roll, the rest moves the bins' centres), then the belief is spread by the odometry noise (a
   Gaussian in position and in heading, from a Table III noise model or a
   :class:`~nightloc.motion.odometry.NoiseModel`, plus small model-error floors) and mixed
   with a little uniform belief (a kidnapped robot is found again). Map-frame displacements move
   a position-only belief (they carry no turn: heading bins would go stale); an unknown motion
   spreads the belief widely;
2. **updates** by the frame's whole rotational SAD table: for every heading bin and reference the
   score of the shift that turns the reference into that heading (interpolated between columns),
   ``likelihood = exp(-lambda (score - s_min))`` with ``lambda = likelihood_gain / (median - min)``
   of the frame's per-reference minimum scores (scores beyond ``score_cap`` x (median - min)
   above the lowest count as that: one frame cannot erase a place), interpolated onto the grid with the map's
   weights (in log space);
3. **estimates** position (the marginal's peak refined to the mean of the cells around it),
   heading, covariance, the heading's variance, ``credible_radius`` and ``confidence`` (the belief within
   ``confidence_radius`` metres of the estimate: low means lost).

The arithmetic runs in the compiled core (``nightloc/grid_filter.hpp``), one call per frame with
the GIL released; ``tests/filter_oracle.py`` is the same filter in numpy.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from .. import _core
from ..config import params_section
from ..motion.odometry import MapDisplacement, NoiseModel, RobotMotion, noise_model, wrap_angle
from ..schema import CoreTable, Range, core_names, own_field
from .heatmap import HeatMapper

__all__ = ["MOTION_NONE", "MOTION_UNKNOWN", "FilterParams", "FilterState", "GridFilter", "table_window"]

#: Motion codes of the core: no prediction (the first frame), unknown motion, map frame, robot frame.
MOTION_NONE, MOTION_UNKNOWN, MOTION_MAP, MOTION_ROBOT = 0, 1, 2, 3

#: The core's settings table (``GridFilterSettings`` in nightloc/grid_filter.hpp): the one place the
#: defaults, ranges, units and docs of :class:`FilterParams`' core fields (and
#: ``LocalizationParams.confidence_radius``) are written.
GRID_FILTER_SETTINGS = CoreTable(_core.GridFilterSettings)
_GRID = GRID_FILTER_SETTINGS


@params_section("filter")
@dataclass(frozen=True)
class FilterParams:
    """The grid filter's tunables (TOML ``[filter]``); the odometry noise is the localizer's
    ``odometry_noise``. Defaults were tuned on the project's synthetic world (docs/localization.md);
    the fields the core holds take theirs, with their ranges, from the core's ``GridFilterSettings``
    table (:mod:`nightloc.schema`; :meth:`core_settings` is the one conversion).

    Attributes:
        heading_bins: heading bins; 0 = one per panorama column (48 for the paper's images, so a
            column shift is one bin). Maps without headings or forward cameras keep a
            position-only belief whatever this says.
        likelihood_gain: kappa of ``lambda = kappa / (median - min)`` of the frame's minimum
            scores: how sharply one frame's scores decide (higher = trusts images more).
        position_floor: metres of Gaussian blur per prediction added in quadrature to the
            odometry's distance noise (grid and motion-model error).
        heading_floor: radians of heading blur per prediction added in quadrature to the
            odometry's heading noise.
        uniform_floor: share of the belief spread uniformly over the grid at each prediction (a
            kidnapped robot is found again; a belief never dies out).
        unknown_spread: metres of Gaussian blur when the motion is unknown (``odometry=None``).
        credibility: mass of the disk whose radius is reported as ``credible_radius``.
        estimate_window: cells on each side of the marginal's peak averaged into the position
            (and whose heading histogram gives the heading).
        settle_frames: the first frames after the start (or ``reset()``) are tempered: frame k
            (from 0) weighs ``min(1, (k + 1) / settle_frames)`` of ``likelihood_gain``, so that a
            few frames agreeing on a look-alike place do not make the belief certain of it; 0 or
            1: every frame weighs the same.
        field_of_view: a forward camera's horizontal field of view, degrees (maps of forward
            images, ``PreparationParams(wrap=False)``, with headings: heading bins whose
            likelihood uses the references in view; panoramas ignore it).
        forward_window: a forward camera's column window: each reference is compared at column
            offsets -w .. w (the heading differences within w columns' worth of the field of
            view); 0: a quarter of the image's width.
        row_window: row offsets -r .. r searched for every comparison (a tilting robot: its
            camera pitches; either camera); 0: none.
        negligible: a heading bin whose largest value after the last frame is below this share of
            the belief's largest moves with the odometry without the position blur (each of its
            cells off by at most that share of the peak; most bins of a belief that has settled
            are such, and the blur is most of an update); 0 blurs every bin.
        score_cap: an outlier-robust likelihood: a score more than ``score_cap`` x (median - min)
            of the frame's minimum scores above its lowest counts as that much, so one frame
            weighs against a place by at most ``exp(-likelihood_gain * score_cap)`` (a frame that
            matches a look-alike cannot erase the place the odometry points to); 0: no cap.
        lookalike_places: a map of P places (distinct reference positions) with P above this
            caps at ``score_cap * ln(lookalike_places) / ln(P)`` instead: the more places, the
            more often a frame's best match is a look-alike, and the less one frame may weigh
            against the place the odometry carries (a lawn of 900 places: 0.89 x score_cap); 0:
            every map the same.
    """

    heading_bins: int = _GRID.field("heading_bins")
    likelihood_gain: float = _GRID.field("likelihood_gain")
    position_floor: float = _GRID.field("position_floor")
    heading_floor: float = _GRID.field("heading_floor")
    uniform_floor: float = _GRID.field("uniform_floor")
    unknown_spread: float = _GRID.field("unknown_spread")
    credibility: float = _GRID.field("credibility")
    estimate_window: int = _GRID.field("estimate_window")
    negligible: float = _GRID.field("negligible")
    settle_frames: int = _GRID.field("settle_frames")
    field_of_view: float = own_field(90.0, unit="degrees", range=Range(0, 360, min_open=True))
    forward_window: int = own_field(0, unit="columns", range=Range(0, 1000))
    row_window: int = own_field(0, unit="rows", range=Range(0, 1000))
    score_cap: float = _GRID.field("score_cap")
    lookalike_places: float = _GRID.field("lookalike_places")

    def validate(self) -> None:
        """The core's ``validate()`` of the settings it holds (every field's range is checked on
        construction, from the table)."""
        self.core_settings().validate()

    def core_settings(
        self, noise: NoiseModel | None = None, confidence_radius: float | None = None
    ) -> _core.GridFilterSettings:
        """The core's ``GridFilterSettings``: every field of this class that the core holds, the
        odometry noise per step (``None``: the core's default) and ``confidence_radius`` metres
        (``None``: the core's default). ``heading_bins`` 0 stays 0: the core makes it one bin per
        image column."""
        settings = _core.GridFilterSettings()
        for name in _CORE_FIELDS:
            setattr(settings, name, getattr(self, name))
        if noise is not None:
            settings.distance_std = noise.distance_std
            settings.heading_std = noise.heading_std
            settings.distance_per_metre = noise.distance_per_metre
            settings.heading_per_radian = noise.heading_per_radian
        if confidence_radius is not None:
            settings.confidence_radius = float(confidence_radius)
        return settings


#: The fields of :class:`FilterParams` the core's settings hold (the others are the map's or
#: the localizer's: the forward camera, the row window).
_CORE_FIELDS = tuple(core_names(FilterParams))


@dataclass(frozen=True)
class FilterState:
    """One step of the filter, as the core returns it (positions in metres, radians, m^2).

    Attributes:
        x, y, heading: the estimate; heading NaN when the belief is position-only.
        covariance: ``(2, 2)`` of the marginal belief about its mean.
        credible_radius: metres around ``(x, y)`` holding ``credibility`` of the belief.
        confidence: belief within ``confidence_radius`` of ``(x, y)``.
        cell: row-major index of the marginal's peak; ``flat``: the marginal had no peak.
        scores: ``(N,)`` the frame's minimum scores per reference, ``shifts`` their best shifts
            (None for a prediction without a frame).
        heading_variance: rad^2, the belief's heading histogram about its circular mean (at most
            pi^2); NaN when the belief is position-only.
    """

    x: float
    y: float
    heading: float
    covariance: np.ndarray
    credible_radius: float
    confidence: float
    cell: int
    flat: bool
    scores: np.ndarray | None = None
    shifts: np.ndarray | None = None
    heading_variance: float = math.nan


def table_window(columns: int, n_shifts: int, has_headings: bool, params: FilterParams) -> tuple[int, int]:
    """The translation window ``(columns, rows)`` of the filter's tables for images of ``columns``
    columns searched at ``n_shifts`` shifts: a forward camera (one shift) with headings compares
    at column offsets within ``params.forward_window`` (0: a quarter of the width); every search
    at row offsets within ``params.row_window``. What ``shift_table`` takes as ``shift_window``."""
    forward = n_shifts == 1 and columns > 1  # a forward camera (wrap=False): one shift, 0
    window_columns = (params.forward_window or max(columns // 4, 1)) if forward and has_headings else 0
    if window_columns >= columns:
        raise ValueError(f"forward_window must be below the image's {columns} columns, got {window_columns}")
    return window_columns, params.row_window


#: The core's motion arguments ``(kind, a, b, c)`` (see :func:`motion_code`).
MotionCode = tuple[int, float, float, float]


def motion_code(motion: object) -> MotionCode:
    """The core's ``(kind, a, b, c)`` of an odometry value already checked by ``as_motion``."""
    if motion is None:
        return MOTION_UNKNOWN, 0.0, 0.0, 0.0
    if isinstance(motion, MapDisplacement):
        return MOTION_MAP, motion.dx, motion.dy, 0.0
    if isinstance(motion, RobotMotion):
        return MOTION_ROBOT, motion.forward, motion.left, motion.turn
    raise TypeError(f"odometry must be MapDisplacement, RobotMotion or None, got {type(motion).__name__}")


class GridFilter:
    """The compiled filter for one map and grid (what :class:`~nightloc.Localizer` drives).

    Args:
        mapper: the localizer's :class:`~nightloc.localization.heatmap.HeatMapper` (grid,
            interpolation weights, places).
        headings: ``(N,)`` reference headings (radians) or None.
        columns: columns of the prepared images (a panorama: columns per 360 degrees).
        shifts: the column shifts matched (None = all columns, a panorama; [0]: a forward camera).
        params: :class:`FilterParams`.
        noise: the odometry noise per step (a Table III model number or a NoiseModel).
        confidence_radius: metres; confidence = belief within it.
        learned: ``(N,)`` uint8, 1 for a reference learned on a night (evidence about its day
            reference per frame, :mod:`nightloc.localization.day_scale`), or None.
    """

    def __init__(
        self,
        mapper: HeatMapper,
        headings: np.ndarray | None,
        columns: int,
        shifts: list | None,
        params: FilterParams,
        noise: int | NoiseModel,
        confidence_radius: float,
        learned: np.ndarray | None = None,
    ):
        self.params = params
        self.noise = noise_model(noise)
        self.mapper = mapper
        self.shifts = np.arange(columns, dtype=np.int32) if shifts is None else np.asarray(shifts, dtype=np.int32)
        window_columns, _ = table_window(columns, len(self.shifts), headings is not None, params)
        #: The table's columns: the shifts, or a forward camera's column offsets -w .. w.
        self.columns = (
            np.arange(-window_columns, window_columns + 1, dtype=np.int32) if window_columns else self.shifts.copy()
        )
        #: The search's translation window (columns, rows): what ``shift_table`` takes.
        self.window = (window_columns, params.row_window)
        self.field_of_view = math.radians(params.field_of_view) if window_columns else 0.0
        place_of_ref = mapper.place_of_ref
        grid = mapper.grid
        self.core = _core.GridFilter(
            mapper._core_weights,
            grid.x0,
            grid.y0,
            grid.dx,
            grid.dy,
            place_of_ref,
            None if headings is None else np.ascontiguousarray(headings, dtype=np.float64),
            int(columns),
            self.shifts,
            params.core_settings(self.noise, confidence_radius),
            self.field_of_view,
            self.window[0],
            self.window[1],
        )
        #: ``(N,)`` uint8 learned flags the core was given, or None (a day map).
        self.learned = None if learned is None else np.ascontiguousarray(learned, dtype=np.uint8)
        if self.learned is not None:
            self.core.set_learned(self.learned)

    def __copy__(self) -> GridFilter:
        return self._copy(self.mapper)

    def __deepcopy__(self, memo: dict) -> GridFilter:
        return self._copy(copy.deepcopy(self.mapper, memo))

    def _copy(self, mapper: HeatMapper) -> GridFilter:
        """A filter over ``mapper`` (this one's or a copy) in this one's state, bit for bit (the
        core's copy; the interpolation weights it shares are immutable)."""
        clone = object.__new__(GridFilter)
        clone.__dict__.update(self.__dict__)
        clone.mapper = mapper
        clone.core = self.core.__copy__()
        return clone

    @property
    def settings(self) -> _core.GridFilterSettings:
        """A copy of the settings the core runs with (heading bins resolved, the odometry noise as
        last set; what map files store)."""
        return self.core.settings

    @property
    def pose_mode(self) -> bool:
        """Whether the belief holds headings now (robot-frame odometry) or only positions."""
        return bool(self.core.pose_mode)

    @property
    def can_pose(self) -> bool:
        """Whether the filter has heading bins at all (map headings and a full panorama)."""
        return bool(self.core.can_pose)

    def set_noise(self, noise: int | NoiseModel) -> None:
        """Replaces the odometry noise model (a Table III number or a NoiseModel)."""
        self.noise = noise_model(noise)
        noise = self.noise
        self.core.set_noise(noise.distance_std, noise.heading_std, noise.distance_per_metre, noise.heading_per_radian)

    def step_image(self, query: np.ndarray, refs: np.ndarray, motion: MotionCode, threads: int) -> FilterState:
        """Predicts by ``motion`` (a :func:`motion_code`), matches ``query`` against ``refs``
        (prepared uint8 images) and updates: one call into the core."""
        estimate, scores, shifts = self.core.step_image(query, refs, *motion, threads)
        return _state(estimate, scores, shifts)

    def step_table(self, table: np.ndarray, motion: MotionCode) -> FilterState:
        """Like :meth:`step_image` from the frame's rotational SAD table ``(N, n_shifts)`` float32."""
        estimate, scores, shifts = self.core.step_table(table, *motion)
        return _state(estimate, scores, shifts)

    def step_table_with_prior(self, table: np.ndarray, motion: MotionCode) -> tuple[FilterState, np.ndarray]:
        """:meth:`step_table`, and the prior it measured: the belief over position predicted to
        the frame, ``(grid_height, grid_width)`` float64 summing to 1 (what :meth:`predict` then
        :meth:`marginal` give, without moving the belief twice)."""
        (estimate, scores, shifts), prior = self.core.step_table_with_prior(table, *motion)
        return _state(estimate, scores, shifts), prior

    def predict(self, motion: MotionCode) -> FilterState:
        """Only the prediction (no frame): the belief moves and spreads."""
        self.core.predict(*motion)
        return _state(self.core.estimate(), None, None)

    def estimate_belief(self, marginal: np.ndarray) -> FilterState:
        """The belief replaced by ``marginal`` ``(grid_height, grid_width)`` float32 summing to 1
        (position mode) and its estimate."""
        self.core.set_belief(marginal[np.newaxis], False, 0.0)
        return _state(self.core.estimate(), None, None)

    def marginal(self) -> np.ndarray:
        """``(grid_height, grid_width)`` float64: the belief summed over heading (sums to 1)."""
        return self.core.marginal()

    def belief(self) -> np.ndarray:
        """``(bins, grid_height, grid_width)`` float64 (one bin in position mode), sums to 1;
        bin b is centred on ``offset + 2 pi b / bins`` radians."""
        return self.core.belief()

    @property
    def offset(self) -> float:
        """Radians: the centre of heading bin 0 (the turns' remainder below one bin)."""
        return float(self.core.offset)

    def reset(self) -> None:
        """Uniform belief."""
        self.core.reset()


def _state(estimate: tuple, scores: np.ndarray | None, shifts: np.ndarray | None) -> FilterState:
    x, y, heading, cxx, cxy, cyy, radius, confidence, cell, flat, heading_var = estimate
    covariance = np.array([[cxx, cxy], [cxy, cyy]])
    return FilterState(
        float(x),
        float(y),
        float(wrap_angle(float(heading))) if math.isfinite(heading) else math.nan,
        covariance,
        float(radius),
        float(confidence),
        int(cell),
        bool(flat),
        scores,
        shifts,
        float(heading_var) if math.isfinite(heading_var) else math.nan,  # one NaN: estimates compare with ==
    )
