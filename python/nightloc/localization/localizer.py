"""The streaming 2D localizer: camera frame + odometry in, position and heading out.

::

    ref_map = nightloc.ReferenceMap.load("garden.npz")
    loc = nightloc.Localizer(ref_map, seq_len=7)
    for frame, (dx, dy) in camera_and_odometry():
        est = loc.update(frame, (dx, dy))          # or nightloc.RobotMotion(forward, left, turn)
        print(est.x, est.y, est.heading, est.ref_index, est.confidence)

Each update (the paper's pipeline, docs/design.md steps 2-6):

1. prepares the frame with the map's own parameters (skipped for a prepared image);
2. matches it against every reference, all rotations (eqs. 2-3, the compiled core);
3. turns the scores into a heat map over the grid (:mod:`nightloc.localization.heatmap`, eq. 4);
4. sums it with the heat maps of the previous ``seq_len - 1`` frames, each translated by the
   odometry displacement since (:mod:`nightloc.localization.sequence`), and takes the hottest cell;
5. estimates the heading from the reference closest to the estimate: its heading plus the
   rotational match's relative heading (beyond the paper; NaN when the map has no headings).

Odometry is the motion since the previous update (:mod:`nightloc.localization.odometry`): a map-frame
``(dx, dy)`` / :class:`MapDisplacement`, or a robot-frame :class:`RobotMotion`, which is rotated
into the map frame with the heading estimate (dead-reckoned from the previous estimate by the
motion's turn). ``None`` means the motion is unknown: the sequence restarts from this frame.
At the start, or after a restart, the sequence holds the frames it has (fewer than ``seq_len``).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from .._validate import MAX_GRID_CELLS, MAX_SEQUENCE_CELLS, StreamGuard, metres, thread_count
from ..config import params_section
from ..io.reference_map import ReferenceMap
from ..matching.sad import MatchResult, match
from .heatmap import HeatMapper
from .odometry import Motion, RobotMotion, as_motion, robot_steps_to_map, wrap_angle
from .sequence import cumulative_offsets

__all__ = ["Estimate", "LocalizationParams", "Localizer"]

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
        seq_len: frames per sequence, n (the paper: 1-10; its headline figures use 7).
        interpolation: linear interpolation of scores between references (True) or the nearest
            reference (False; the estimate is then a reference position, the paper's comparison).
        outside: value of cells outside the reference hull: ``"lowest"`` (the frame's lowest
            heat: never preferred) or ``"nearest"`` (their nearest reference's).
        inversion: scores to heat, see :func:`nightloc.localization.heatmap.invert_scores` (``"range"``:
            best 1, worst 0 per frame, so each frame weighs the same in a sequence).
        confidence_radius: metres around the peak ignored when finding the second-best place.
    """

    grid_width: int = 100
    grid_height: int = 100
    margin: float = 0.25
    seq_len: int = 7
    interpolation: bool = True
    outside: Literal["lowest", "nearest"] = "lowest"
    inversion: Literal["range", "zscore", "negate"] = "range"
    confidence_radius: float = 1.0

    def validate(self) -> None:
        """Checks ranges (called on construction); raises ValueError naming the field."""
        for name in ("grid_width", "grid_height"):
            if getattr(self, name) < 2:
                raise ValueError(f"{name} must be >= 2 cells, got {getattr(self, name)}")
        if self.grid_width * self.grid_height > MAX_GRID_CELLS:
            raise ValueError(
                f"grid of {self.grid_width}x{self.grid_height} cells is too large (at most {MAX_GRID_CELLS} cells, "
                f"MAX_GRID_CELLS)"
            )
        metres(self.margin, "margin", minimum=0.0)
        if not 1 <= self.seq_len <= MAX_SEQ_LEN:
            raise ValueError(f"seq_len must be 1..{MAX_SEQ_LEN} frames, got {self.seq_len}")
        cells = self.seq_len * self.grid_height * (self.grid_width + 1)  # the sequence's padded float32 maps
        if cells > MAX_SEQUENCE_CELLS:
            raise ValueError(
                f"seq_len {self.seq_len} over a {self.grid_width}x{self.grid_height} grid needs {cells} float32 "
                f"cells, more than {MAX_SEQUENCE_CELLS} (MAX_SEQUENCE_CELLS, 512 MiB); shorten the sequence or "
                f"coarsen the grid"
            )
        metres(self.confidence_radius, "confidence_radius", minimum=0.0)


@dataclass(frozen=True)
class Estimate:
    """One localizer update's answer.

    Attributes:
        x, y: position estimate, metres in the map frame.
        heading: radians in (-pi, pi], or NaN when the map has no headings.
        ref_index: the reference closest to the estimate.
        confidence: 0..1, how much the peak stands out (:class:`nightloc.localization.heatmap.HeatEstimate`).
        frames: frames fused (1 .. seq_len).
        best_ref: the single frame's best match (lowest score), and ``score`` its score.
        heatmap: the fused heat map ``(grid_height, grid_width)`` (row 0 = lowest y), when asked.
        frame_heatmap: this frame's own heat map, when asked.
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

    @property
    def position(self) -> np.ndarray:
        """``(2,)`` the estimate ``[x, y]`` in metres."""
        return np.array([self.x, self.y])


class Localizer:
    """Streaming 2D localization against a reference map (single frames or sequences).

    Args:
        ref_map: the :class:`~nightloc.ReferenceMap` (prepared day images with poses).
        params: :class:`LocalizationParams` (default: the paper's values, seq_len 7).
        threads: matching threads (default 1: one core per frame, the robot's budget).
        **overrides: fields of ``params`` to replace, e.g. ``seq_len=10, interpolation=False``.

    The grid, triangulation and interpolation weights are computed here, once.

    A localizer is one stream of frames: :meth:`update` from two threads at once raises
    RuntimeError (the order of the frames would be a race); use one localizer per thread (they
    may share the map). ``copy.copy`` gives an independent localizer with the same state that
    shares the map and the grid; ``copy.deepcopy`` copies those too.
    """

    def __init__(
        self, ref_map: ReferenceMap, params: LocalizationParams | None = None, *, threads: int = 1, **overrides: Any
    ):
        if not isinstance(ref_map, ReferenceMap):
            raise TypeError(f"ref_map must be a nightloc.ReferenceMap, got {type(ref_map).__name__}")
        params = LocalizationParams() if params is None else params
        if not isinstance(params, LocalizationParams):
            raise TypeError(f"params must be a LocalizationParams, got {type(params).__name__}")
        if overrides:
            names = {f.name for f in dataclasses.fields(LocalizationParams)}
            unknown = sorted(set(overrides) - names)
            if unknown:
                raise TypeError(f"unknown localization parameter(s) {unknown}; known: {sorted(names)}")
            params = dataclasses.replace(params, **overrides)
        self.ref_map = ref_map
        self.params = params
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
        self._prepared_shape = (ref_map.params.height, ref_map.params.width)
        self._sequence = self.mapper.sequence(params.seq_len)
        self._guard = StreamGuard("Localizer")  # one thread at a time (see the class docstring)
        self.reset()

    def __copy__(self) -> Localizer:
        with self._guard("copy"):
            clone = object.__new__(Localizer)
            clone.__dict__.update(self.__dict__)
            clone._sequence = copy.deepcopy(self._sequence)  # the frames' heat maps: not shared
            clone._motions = deque(self._motions, maxlen=self._motions.maxlen)
            clone._guard = StreamGuard("Localizer")
        return clone

    def with_seq_len(self, seq_len: int) -> Localizer:
        """A new localizer for the same map and parameters but another sequence length.

        It shares this one's grid and interpolation weights (no recomputation) and starts with
        an empty sequence; useful to evaluate several sequence lengths.
        """
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
    def heading(self) -> float:
        """The current heading estimate (radians, NaN if unknown)."""
        return self._heading

    def reset(self) -> None:
        """Forgets the sequence and the heading (e.g. after the robot was carried elsewhere)."""
        with self._guard("reset"):
            self._reset()

    def _reset(self) -> None:
        self._sequence.clear()  # the frames' excess heat maps and fill values (in the core)
        self._motions: deque[Motion] = deque(maxlen=max(self.params.seq_len - 1, 1))
        self._heading = math.nan

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
        result = match(query, self.ref_map.images, shifts=self._shifts, threads=self.threads)
        return self.update_match(result, odometry, return_heatmap=return_heatmap)

    def update_match(self, result: MatchResult, odometry: object = None, *, return_heatmap: bool = False) -> Estimate:
        """Like :meth:`update`, from a frame already matched against the map (a MatchResult)."""
        with self._guard("update"):
            return self._update_match(result, odometry, return_heatmap)

    def _update_match(self, result: MatchResult, odometry: object, return_heatmap: bool) -> Estimate:
        if not isinstance(result, MatchResult):
            raise TypeError(f"result must be a nightloc.MatchResult, got {type(result).__name__}")
        if result.scores.shape != (len(self.ref_map),):
            raise ValueError(
                f"result has {result.scores.shape[0]} scores but the map has {len(self.ref_map)} references"
            )
        motion = as_motion(odometry)
        headings = self.ref_map.headings
        stored = self._sequence.size
        if isinstance(motion, RobotMotion) and headings is None and stored:
            raise ValueError(
                "robot-frame odometry (RobotMotion) needs a heading estimate, and there is none: the reference "
                "map has no headings; pass map-frame displacements (MapDisplacement or (dx, dy)) instead"
            )
        values, fill = self.mapper.place_excess(result.scores)  # checks the scores before any state changes
        if isinstance(motion, RobotMotion) and math.isfinite(self._heading):
            predicted = self._heading + motion.turn
        elif headings is not None:
            predicted = float(headings[result.index] + result.headings[result.index])
        else:
            predicted = math.nan
        restart = bool(stored) and motion is None
        earlier = 0 if restart else min(stored, self.params.seq_len - 1)  # frames fused with this one
        if earlier:
            motions = ([*list(self._motions), motion])[-earlier:]
            steps = robot_steps_to_map(motions, predicted)
            offsets = np.ascontiguousarray(self.grid.to_cells(cumulative_offsets(steps)))
            if not np.isfinite(offsets).all():
                raise ValueError(f"odometry gives non-finite displacements: {offsets.tolist()}")
        else:
            offsets = _NO_OFFSETS
        # the update is valid: change the state
        if restart:
            self._sequence.clear()
            self._motions.clear()
        elif stored:
            self._motions.append(motion)
        self._sequence.push(values, fill)
        fill_sum, cell, peak, floor, second = self._sequence.fuse_peak(offsets)
        heatmap = self._sequence.fused() + fill_sum if return_heatmap else None
        frame_heatmap = self._sequence.frame(-1) + fill if return_heatmap else None
        found = self.mapper.estimate_from_peak(cell, peak, floor, second, result.scores)
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
