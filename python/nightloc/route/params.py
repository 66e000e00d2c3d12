"""Parameters of route mode and its presets.

:class:`RouteParams` is the TOML table ``[route]`` (see :mod:`nightloc.config`); OpenSeqSLAM's
parameter names are given in brackets. Two methods search the difference matrix:

* ``method = "filter"`` (the default): a causal Bayes filter over the reference frames
  (:mod:`nightloc.route.filter`), fields ``filter_*``;
* ``method = "seqslam"``: OpenSeqSLAM's straight-line trajectory search, fields ``ds``, ``vmin``,
  ``vmax``, ``uniqueness_radius``, ``mode`` (the speed window ``vmin .. vmax`` is shared with the
  filter's prediction).

Two presets:

* ``"openseqslam"`` reproduces OpenSeqSLAM's defaults bit for bit (images used at their own size,
  Octave's ``rgb2gray``, 8x8 block normalization, D divided by the number of references,
  enhancement R = 10, ds = 10, v = 0.8 ... 1.2, Rwindow = 10, centred trajectories, SeqSLAM);
* ``"nightloc"`` (the default) prepares images the paper's way without histogram equalization
  (grey, area downsample to 48x24, patch normalization with radius 4, no wrap for a forward
  camera: :func:`default_preparation`, chosen by the sweep in ``docs/route_mode.md``), scores
  mean absolute differences per pixel at the best alignment within +-8 columns and +-2 rows of a
  forward camera (``shift_window``, viewpoint tolerance), enhances as OpenSeqSLAM and runs the
  filter.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any, Literal

from .. import _core
from ..config import params_section
from ..preparation.params import PreparationParams
from ..schema import AT_LEAST_0, CoreTable, Range, core_names, own_field

__all__ = [
    "DEFAULT_SHIFT_WINDOWS",
    "DISTANCE_MOTIONS",
    "MOTION_MODELS",
    "ODOMETRY_MOTION",
    "PRESETS",
    "MotionSpeeds",
    "RouteParams",
    "default_preparation",
    "motion_speeds",
    "resolve_params",
    "route_preset",
]

#: The route filter's motion models by name (``filter_motion``, ``nightloc route --motion``): the
#: compiled core's one name table (``route_motion_names()`` in ``nightloc/route_filter.hpp``).
MOTION_MODELS: tuple[str, ...] = tuple(_core.route_motion_names())
#: The models that move by the distance travelled (the registry's ``needs_distances``): they run
#: only where both traverses carry odometry.
DISTANCE_MOTIONS: frozenset[str] = frozenset(m["name"] for m in _core.route_motion_models() if m["needs_distances"])
#: The model route mode runs when both traverses carry odometry and the parameters name none of
#: :data:`DISTANCE_MOTIONS`: the registry's first.
ODOMETRY_MOTION: str = next(name for name in MOTION_MODELS if name in DISTANCE_MOTIONS)

#: The core's tables of the route filter's parameters and of SeqSLAM's search (nightloc/route_filter.hpp,
#: nightloc/seqslam.hpp): the one place the defaults, ranges, units and docs of the fields
#: :class:`RouteParams` shares with them are written.
ROUTE_FILTER_SETTINGS = CoreTable(_core.RouteFilterParams)
TRAJECTORY_SETTINGS = CoreTable(_core.TrajectoryParams)
_FILTER = ROUTE_FILTER_SETTINGS
_SEARCH = TRAJECTORY_SETTINGS

#: The translation window of ``shift_window = None``, per camera: ``(columns, rows)``. On a
#: forward camera +-8 columns and +-2 rows keep a night walk a metre beside the day walk and a
#: camera held lower or higher, tilted by a few degrees or wobbling in the hand; on a panorama
#: (a robot's rigid mount) rows cost on lateral offsets what they bring on vertical changes (the
#: sweep in docs/route_mode.md).
DEFAULT_SHIFT_WINDOWS = {"forward": (8, 2), "panoramic": (0, 0)}


@params_section("route")
@dataclasses.dataclass(frozen=True)
class RouteParams:
    """Route mode parameters.

    Attributes:
        method: ``"filter"`` (causal Bayes filter, the default) or ``"seqslam"`` (trajectory
            search).
        preparation: ``"openseqslam"``: grey with Octave's ``rgb2gray`` (BT.601, rounded half away
            from zero), images kept at their own size, ``block_side`` block normalization;
            ``"nightloc"``: the paper's preparation with a :class:`PreparationParams`.
        block_side: block size of OpenSeqSLAM's normalization, pixels [normalization.sideLength].
        divisor: difference-matrix scale: ``"references"`` divides the sum of absolute
            differences by the number of reference images (OpenSeqSLAM), ``"pixels"`` by the
            image size (mean absolute difference in grey levels).
        circular_shifts: search every circular column shift (360-degree panoramas) instead of
            shift 0 only (forward cameras).
        shift_window: ``(columns, rows)``: viewpoint tolerance; each difference is the best mean
            absolute difference over the overlap of the query moved by up to ``rows`` rows and,
            for a forward camera, ``columns`` columns (:mod:`nightloc.matching.sad`); with
            ``circular_shifts`` every column shift is searched already and ``columns`` is unused.
            Offsets beyond the image are clipped (:meth:`window_for`). ``(0, 0)`` compares one
            alignment (OpenSeqSLAM). None (the default): :data:`DEFAULT_SHIFT_WINDOWS`, ``(8, 2)``
            for a forward camera and ``(0, 0)`` for a panorama, chosen by the sweep in
            ``docs/route_mode.md`` (lateral offsets, camera height and pitch, real day/night and
            seasonal pairs).
        enhance_radius: contrast enhancement over references i-radius .. i+radius [R/2].
        ds: sequence length in frames [matching.ds]. Centred mode rounds it up to even and uses
            ds+1 frames; causal mode uses ds frames ending at the query.
        vmin, vmax: slowest and fastest speeds, references per query frame [matching.vmin,
            vmax]; the speeds searched are (vmin*ds : 1 : vmax*ds) / ds.
        uniqueness_radius: the second-best trajectory excludes anchors within this many
            references of the best [Rwindow/2].
        mode: ``"centred"`` (OpenSeqSLAM: needs ds/2 future frames) or ``"causal"``
            (trajectories end at the current frame; usable online). SeqSLAM only: the filter
            is always causal.
        filter_sharpness: lambda of the filter's likelihood ``exp(-lambda * min(z, clip))``, z the
            frame's (enhanced) difference row standardized by its own mean and standard
            deviation: the evidence one frame carries, per standard deviation of its row.
        filter_clip: z-scores above this count as no evidence against a place (0: a place that
            looks worse than the row's mean is not penalized, so one bad frame cannot rule
            out the true place); ``inf`` disables the clip.
        filter_floor: fraction of the belief spread uniformly over the route each frame, so a
            lost filter finds the route again.
        filter_backward: probability per frame of stepping one reference back (a robot that
            reverses or jitters); the forward advance follows the speed window ``vmin .. vmax``.
        filter_leave, filter_rejoin: per-frame probabilities of leaving the route (to the
            off-route state, whose likelihood is that of a random place) and of rejoining it
            (uniformly).
        filter_window: the confidence of a match is the belief within +-filter_window
            references of it (use the evaluation tolerance).
        filter_min_texture: a prepared query frame whose mean absolute deviation from its own
            mean is below this many grey levels carries proportionally less evidence (a flat
            frame: none, the belief is only predicted); 0 disables the weight.
        filter_motion: the filter's motion model, a name of :data:`MOTION_MODELS` (the models are
            described in docs/route_mode.md; those of :data:`DISTANCE_MOTIONS` move by the distance
            travelled and need odometry in both traverses). Route mode runs
            :data:`ODOMETRY_MOTION` whenever both traverses carry odometry unless told not to
            (:func:`nightloc.route.odometry.motion_plan`).
        filter_speed_min, filter_speed_max, filter_speed_step: the speed model's planes,
            references per query frame (a negative speed: reversing).
        filter_speed_jitter: each plane advances by a speed uniform within +- this of its own,
            references per frame (position noise that needs no change of speed).
        filter_speed_change: standard deviation of the speed's change per frame, references per
            frame.
        filter_speed_tau: frames for a speed to relax back towards the reference's (1); ``inf``:
            no pull.
        filter_speed_cells: position cells per reference of the speed model.
        filter_odometry_noise: relative standard deviation of one frame's odometry advance.
        filter_odometry_jitter: extra position noise per frame of the odometry model,
            references.
        filter_odometry_novelty: a frame's evidence weighs ``min(1, travel / (novelty *
            spacing))`` with the odometry model (spacing: the mean distance between references):
            a robot that has not moved sees nothing new; 0 disables the factor.
        filter_odometry_cells: position cells per reference of the odometry model.
    """

    method: Literal["filter", "seqslam"] = "filter"
    preparation: Literal["nightloc", "openseqslam"] = "nightloc"
    block_side: int = own_field(8, unit="pixels", range=Range(2, math.inf))
    divisor: Literal["pixels", "references"] = "pixels"
    circular_shifts: bool = False
    shift_window: tuple[int, int] | None = own_field(None, unit="pixels (columns, rows)")
    enhance_radius: int = own_field(5, unit="references", range=Range(1, math.inf))
    ds: int = _SEARCH.field("ds")
    vmin: float = _FILTER.field("vmin")
    vmax: float = _FILTER.field("vmax")
    uniqueness_radius: int = _SEARCH.field("uniqueness_radius")
    mode: Literal["centred", "causal"] = _SEARCH.field("mode")
    filter_sharpness: float = _FILTER.field("sharpness")
    filter_clip: float = _FILTER.field("clip")
    filter_floor: float = _FILTER.field("floor")
    filter_backward: float = _FILTER.field("backward")
    filter_leave: float = _FILTER.field("leave")
    filter_rejoin: float = _FILTER.field("rejoin")
    filter_window: int = _FILTER.field("window")
    filter_min_texture: float = own_field(1.0, unit="grey levels", range=AT_LEAST_0)
    filter_motion: str = _FILTER.field("motion")
    filter_speed_min: float = _FILTER.field("speed_min")
    filter_speed_max: float = _FILTER.field("speed_max")
    filter_speed_step: float = _FILTER.field("speed_step")
    filter_speed_jitter: float = _FILTER.field("speed_jitter")
    filter_speed_change: float = _FILTER.field("speed_change")
    filter_speed_tau: float = _FILTER.field("speed_tau")
    filter_speed_cells: int = _FILTER.field("speed_cells")
    filter_odometry_noise: float = _FILTER.field("odometry_noise")
    filter_odometry_jitter: float = _FILTER.field("odometry_jitter")
    filter_odometry_novelty: float = _FILTER.field("odometry_novelty")
    filter_odometry_cells: int = _FILTER.field("odometry_cells")

    def validate(self) -> None:
        """The rules between fields (each field's range is checked on construction, from the
        table): the shift window, SeqSLAM's speeds, the core's rules of the filter's fields, the
        size of SeqSLAM's search."""
        if self.shift_window is not None and min(self.shift_window) < 0:
            raise ValueError(f"shift_window must be (columns, rows) >= 0 pixels, got {self.shift_window}")
        if self.method == "seqslam" and not self.vmin > 0:
            raise ValueError(
                f"vmin must be a speed in (0, 1000] references per frame for SeqSLAM, got {self.vmin} "
                f"(the filter accepts vmin = 0: a robot that stops)"
            )
        try:
            self.core_filter_params().validate()
        except _core.SettingError as error:  # the core's name of the field -> this class's
            raise ValueError(f"{_PARAMS_FIELDS.get(error.setting, error.setting)} {error.requirement}") from None
        ds = self.effective_ds
        speeds = math.floor(self.vmax * ds - self.vmin * ds) + 1
        frames = ds + 1 if self.mode == "centred" else ds
        if speeds * frames > _core.MAX_TRAJECTORY_PLAN_ENTRIES:
            raise ValueError(
                f"{speeds} speeds (vmin {self.vmin} .. vmax {self.vmax} at ds {self.ds}) x {frames} frames is too "
                f"large a search (at most {_core.MAX_TRAJECTORY_PLAN_ENTRIES:.0f}); narrow vmin..vmax or shorten ds"
            )

    def core_filter_params(self) -> _core.RouteFilterParams:
        """The filter's parameters as the compiled core takes them: ``vmin``, ``vmax`` and each
        ``filter_*`` field the core has (its name without the prefix)."""
        core = _core.RouteFilterParams()
        for name, core_name in _CORE_FIELDS.items():
            setattr(core, core_name, getattr(self, name))
        return core

    def method_params(self) -> dict:
        """The fields that the chosen method uses (for summaries): the shared ones, then the
        method's own."""
        shared = (
            "method",
            "preparation",
            "divisor",
            "circular_shifts",
            "shift_window",
            "enhance_radius",
            "vmin",
            "vmax",
        )
        own = (
            tuple(f.name for f in dataclasses.fields(self) if f.name.startswith("filter_"))
            if self.method == "filter"
            else ("ds", "uniqueness_radius", "mode")
        )
        extra = ("block_side",) if self.preparation == "openseqslam" else ()
        values = {name: getattr(self, name) for name in shared + extra + own}
        values["shift_window"] = self.effective_shift_window
        return values

    @property
    def effective_ds(self) -> int:
        """The sequence length the search uses (centred mode: rounded up to even)."""
        return self.ds + self.ds % 2 if self.mode == "centred" else self.ds

    @property
    def shifts(self) -> list | None:
        """Column shifts searched by the difference matrix: None (all) or ``[0]``."""
        return None if self.circular_shifts else [0]

    @property
    def effective_shift_window(self) -> tuple[int, int]:
        """``shift_window``, or the camera's default (:data:`DEFAULT_SHIFT_WINDOWS`) when None."""
        if self.shift_window is not None:
            return self.shift_window
        return DEFAULT_SHIFT_WINDOWS["panoramic" if self.circular_shifts else "forward"]

    def window_for(self, height: int, width: int) -> tuple[int, int]:
        """The translation window the difference matrix searches on ``height x width`` images,
        ``(columns, rows)``: the column part only for a forward camera (panoramas search every
        circular shift), each clipped to the largest offset that leaves an overlap (``width - 1``
        columns, ``height - 1`` rows: the default window also serves tiny images)."""
        columns, rows = self.effective_shift_window
        columns = 0 if self.circular_shifts else min(columns, max(0, width - 1))
        return (columns, min(rows, max(0, height - 1)))

    @property
    def enhance_offset(self) -> str:
        """What follows the z-scores: ``"global_min"`` (centred, OpenSeqSLAM: minus the minimum
        of the whole matrix) or ``"bound"`` (causal: plus the largest possible |z|,
        ``2r/sqrt(2r+1)``, which needs no future frames). The filter always uses ``"bound"``
        (:attr:`search_offset`)."""
        return "global_min" if self.mode == "centred" else "bound"

    @property
    def search_offset(self) -> str:
        """The enhancement offset the chosen method runs with: ``"bound"`` for the filter (causal,
        frame by frame; the filter standardizes each row, so the offset only fixes the rounding),
        :attr:`enhance_offset` for SeqSLAM."""
        return "bound" if self.method == "filter" else self.enhance_offset


#: RouteParams' filter fields and the shared speeds -> the core's RouteFilterParams field of
#: the same meaning (the name without ``filter_``); fields the core lacks (``filter_min_texture``)
#: are Python's own.
_FILTER_FIELDS = tuple(f.name for f in dataclasses.fields(RouteParams) if f.name.startswith("filter_"))
_CORE_FIELDS = core_names(RouteParams, ROUTE_FILTER_SETTINGS)
#: The core's RouteFilterParams field -> the RouteParams field of the same meaning.
_PARAMS_FIELDS = {core_name: name for name, core_name in _CORE_FIELDS.items()}

#: The core's RouteFilterParams field -> the RouteParams field of the same meaning.
_PARAMS_FIELDS = {core_name: name for name, core_name in _CORE_FIELDS.items()}


@dataclasses.dataclass(frozen=True)
class MotionSpeeds:
    """The steady speeds a search follows, reference frames per query frame.

    Attributes:
        search: what follows them, in words (``"speed motion model"``, ``"SeqSLAM"``).
        lowest, highest: the range (``-inf``, ``inf`` for a model that moves by the distance
            travelled).
        fields: the :class:`RouteParams` fields that set ``lowest`` and ``highest`` (the window
            model's ``vmin``, ``vmax``; the speed model's planes and prior), or None.
    """

    search: str
    lowest: float
    highest: float
    fields: tuple[str, ...] | None

    @property
    def bounded(self) -> bool:
        """Whether the search assumes a range of speeds at all."""
        return math.isfinite(self.lowest) or math.isfinite(self.highest)

    def covers(self, ratio: float) -> bool:
        """Whether ``ratio`` (reference frames per query frame) lies in the range (its ends
        included, to 1e-6: a plane's speed or a measured slope may carry rounding)."""
        return self.lowest - 1e-6 <= ratio <= self.highest + 1e-6

    def words(self, option: Callable[[str], str] = str) -> str:
        """The range in words: ``"the speed motion model's 0.5..1.5 (filter_speed_min..filter_speed_max)"``;
        ``option(field)`` names each field as the user sets it (e.g. a command's ``--vmin``)."""
        if not self.bounded:
            return f"the {self.search} (any speed)"
        owner = "SeqSLAM's speeds" if self.search == "SeqSLAM" else f"the {self.search}'s"
        fields = ""
        if self.fields and len(self.fields) == 2:
            fields = f" ({option(self.fields[0])}..{option(self.fields[1])})"
        elif self.fields:
            fields = f" (set by {', '.join(option(field) for field in self.fields)})"
        return f"{owner} {self.lowest:g}..{self.highest:g}{fields}"


def motion_speeds(params: RouteParams, motion: str | None) -> MotionSpeeds:
    """The steady speeds the search of ``params`` follows: the filter's motion model ``motion`` (a
    name of :data:`MOTION_MODELS`; the range and the fields that set it come from the core's
    registry of models: the central 80 % of the model's speed, ``vmin .. vmax`` uniform for the
    window model, the speed prior over its planes for the speed model; any speed for odometry),
    or SeqSLAM's trajectories (``motion`` None: every speed of ``vmin .. vmax`` is searched)."""
    if motion is None:
        return MotionSpeeds("SeqSLAM", params.vmin, params.vmax, ("vmin", "vmax"))
    core = params.core_filter_params()
    core.motion = motion
    lowest, highest, fields = _core.route_motion_speeds(core)
    named = tuple(_PARAMS_FIELDS[field] for field in fields) or None
    return MotionSpeeds(f"{motion} motion model", float(lowest), float(highest), named)


#: Preset name -> parameters.
PRESETS = {
    "nightloc": RouteParams(),
    "openseqslam": RouteParams(method="seqslam", preparation="openseqslam", divisor="references", shift_window=(0, 0)),
}


def route_preset(name: str) -> RouteParams:
    """The :class:`RouteParams` of a preset (``"nightloc"`` or ``"openseqslam"``)."""
    if name not in PRESETS:
        raise ValueError(f"unknown route preset {name!r}; choose one of {', '.join(sorted(PRESETS))}")
    return PRESETS[name]


def resolve_params(params: RouteParams | str | None = None, **overrides: object) -> RouteParams:
    """``params`` (a :class:`RouteParams`, a preset name, or None for ``"nightloc"``) with the
    given fields replaced (``None`` values are ignored)."""
    if params is None:
        base = PRESETS["nightloc"]
    elif isinstance(params, str):
        base = route_preset(params)
    elif isinstance(params, RouteParams):
        base = params
    else:
        raise TypeError(f"params must be a RouteParams or a preset name, got {type(params).__name__}")
    changes: dict[str, Any] = {key: value for key, value in overrides.items() if value is not None}
    unknown = set(changes) - {field.name for field in dataclasses.fields(RouteParams)}
    if unknown:
        raise TypeError(f"unknown route parameter(s): {', '.join(sorted(unknown))}")
    return dataclasses.replace(base, **changes) if changes else base


def default_preparation(params: RouteParams) -> PreparationParams:
    """The preparation of the ``"nightloc"`` preset: grey, 48x24, no histogram equalization,
    patch normalization with radius 4, the window wrapping only when circular shifts are
    searched. Equalization is off because patch normalization already removes the local gain
    and offset, and equalization amplifies sensor noise in dark frames; the sweep over
    equalization, radius and resolution on Nordland and Gardens Point that chose it is in
    ``docs/route_mode.md``. (A ``[preparation]`` table given by the user starts from
    :class:`PreparationParams`' own defaults, which equalize.)"""
    return PreparationParams(wrap=params.circular_shifts, equalize="none")
