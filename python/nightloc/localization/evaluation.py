"""Evaluation the paper's way: distance errors over sequence lengths, noise models, interpolation.

For a reference map and a query traverse with ground-truth poses, :func:`evaluate` runs the
:class:`~nightloc.Localizer` over the whole query traverse (in its order, as a robot would see
it), with the paper's method (``methods`` holds ``"paper"``, the default) for every combination of

* sequence length ``n`` (default 1..10; at the start of the traverse a sequence holds the frames
  it has),
* odometry noise model (the paper's Table III, default 0, 1, 2, 3; odometry simulated from the
  query's ground truth, see :mod:`nightloc.motion.odometry`),
* interpolation on / off,
* repeat (independent noise draws; the same draw is shared by all ``n`` and both interpolation
  settings, so their comparison is paired),

and, when ``methods`` holds ``"filter"``, with the grid Bayes filter once per noise model, draw
and interpolation setting (told the run's noise model; its rows' ``seq_len`` holds the frames
seen so far, 1..N). It records, per query frame, the estimate and its distance error (the
paper's Figures 10-12, 16-18, 21-22). Frames are matched against the map once
(:func:`nightloc.difference_matrix`, and for the filter the whole rotational tables); each
configuration reuses those scores.

Odometry (``EvaluationSettings.odometry``): ``"map"`` simulates map-frame displacements from the
ground truth (the paper), ``"robot"`` wheel odometry (:class:`~nightloc.RobotMotion`), both with
the Table III noise models; ``"log"`` uses the query's own ``odometry.csv`` (a robot's real
odometry evaluated against its poses; ``noise_model`` is then -1 in the outputs and the filter
assumes ``log_noise``: by default the step-scaled ``WHEEL_ODOMETRY_NOISE`` for wheel odometry,
Table III model 1 for map-frame steps).

Outputs (:meth:`Evaluation.write_errors_csv`, :meth:`Evaluation.write_summary_csv`, written
atomically) have the headers :data:`ERRORS_HEADER` and :data:`SUMMARY_HEADER`.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Union

import numpy as np

from .._validate import MAX_REPEATS
from ..errors import DatasetError
from ..io.atomic import atomic_file
from ..io.traverse import Traverse, load_traverse
from ..mapping.reference_map import ReferenceMap
from ..matching.sad import MatchResult, difference_matrix, rotational_sad, shift_table, shifts_to_headings
from ..motion.odometry import (
    NOISE_MODELS,
    NoiseModel,
    log_noise_model,
    noise_model,
    simulate_map_odometry,
    simulate_robot_odometry,
    traverse_odometry,
)
from ..preparation.preparer import Preparer
from ..progress import progress
from .grid_filter import FilterParams, table_window
from .localizer import Estimate, LocalizationParams, Localizer
from .tail import FIRST_FRAME, TailMetrics, tail_metrics

__all__ = [
    "ERRORS_COLUMNS",
    "ERRORS_HEADER",
    "EVALUATION_METHODS",
    "LOG_NOISE_MODEL",
    "SUMMARY_COLUMNS",
    "SUMMARY_HEADER",
    "Evaluation",
    "EvaluationSettings",
    "QueryMatches",
    "SummaryRow",
    "align_to_map",
    "evaluate",
    "map_alignment",
    "match_traverse",
    "replay",
    "simulated_odometry",
]

if TYPE_CHECKING:
    from ..mapping.alignment import RigidTransform2D

PathLike = Union[str, "os.PathLike[str]"]


def _metres(value: float) -> str:
    return f"{float(value):.4f}"


def _on_off(value: object) -> str:
    return "on" if value else "off"


#: Columns of ``errors.csv``, one row per query frame and configuration: name -> how a value is
#: written. The one list of the columns: :data:`ERRORS_HEADER`, the rows and
#: :attr:`Evaluation.columns` follow it.
ERRORS_COLUMNS: dict[str, Callable[[Any], object]] = {
    "query": str,
    "image": str,
    "seq_len": int,
    "noise_model": int,
    "interpolation": _on_off,
    "repeat": int,
    "x_est": _metres,
    "y_est": _metres,
    "x_true": _metres,
    "y_true": _metres,
    "error_m": _metres,
    "ref_index": int,
    "method": str,
}
ERRORS_HEADER: tuple[str, ...] = tuple(ERRORS_COLUMNS)
#: Columns of ``summary.csv``, one row per (seq_len, noise_model, interpolation, method): name ->
#: how a :class:`SummaryRow`'s field of that name is written. The filter's rows summarize all its
#: frames and have seq_len 0. ``n``, ``median_m``, ``mean_m`` and ``p90_m`` count every frame; the
#: tail (``p95_m``, ``share_over_1m``, ``longest_run_over_1m``:
#: :func:`~nightloc.localization.tail.tail_metrics`) the frames from the 10th on, the longest run
#: the worst of the configuration's runs (queries x draws). The one list of the columns:
#: :data:`SUMMARY_HEADER`, :class:`SummaryRow`'s fields and the rows follow it.
SUMMARY_COLUMNS: dict[str, Callable[[Any], object]] = {
    "seq_len": int,
    "noise_model": int,
    "interpolation": _on_off,
    "n": int,
    "median_m": _metres,
    "mean_m": _metres,
    "p90_m": _metres,
    "p95_m": _metres,
    "share_over_1m": lambda share: f"{share:.4f}",
    "longest_run_over_1m": int,
    "method": str,
}
SUMMARY_HEADER: tuple[str, ...] = tuple(SUMMARY_COLUMNS)
#: Methods :func:`evaluate` runs.
EVALUATION_METHODS = ("paper", "filter")
#: ``noise_model`` of rows whose odometry is the query's own log.
LOG_NOISE_MODEL = -1


@dataclass(frozen=True)
class EvaluationSettings:
    """Which configurations :func:`evaluate` runs.

    Attributes:
        seq_lengths: sequence lengths n (default 1..10).
        noise_models: Table III noise models (default 0, 1, 2, 3).
        interpolation: interpolation settings to run (default on and off).
        repeats: independent odometry noise draws per noise model (model 0 has no noise, so it
            runs once whatever this says).
        seed: seed of the noise draws (draw r of model m uses ``default_rng([seed, m, r])``).
        odometry: ``"map"``: map-frame displacements with noise on step length and direction
            (the paper); ``"robot"``: wheel-odometry readings (noise on step length and turn;
            the paper's method rotates them into the map with its own heading estimate, the
            filter per heading bin); needs headings; ``"log"``: the query's ``odometry.csv``
            (noise models and repeats do not apply).
        methods: ``("paper",)`` (default, the paper's experiments), ``("filter",)`` or both.
        log_noise: the noise model the filter assumes for ``odometry="log"`` (a Table III
            number or a NoiseModel; None: :func:`~nightloc.motion.odometry.log_noise_model`
            of the log, the step-scaled wheel model for robot-frame steps, else model 1).
    """

    seq_lengths: tuple[int, ...] = tuple(range(1, 11))
    noise_models: tuple[int, ...] = (0, 1, 2, 3)
    interpolation: tuple[bool, ...] = (True, False)
    repeats: int = 1
    seed: int = 0
    odometry: Literal["map", "robot", "log"] = "map"
    methods: tuple[str, ...] = ("paper",)
    log_noise: int | NoiseModel | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "seq_lengths", _unique_ints(self.seq_lengths, "seq_lengths", 1))
        object.__setattr__(self, "noise_models", _unique_ints(self.noise_models, "noise_models", 0))
        for model in self.noise_models:
            noise_model(model)
        modes = tuple(dict.fromkeys(bool(v) for v in self.interpolation))
        if not modes:
            raise ValueError("interpolation needs at least one setting (True and/or False)")
        object.__setattr__(self, "interpolation", modes)
        if (
            isinstance(self.repeats, bool)
            or not isinstance(self.repeats, (int, np.integer))
            or not 1 <= self.repeats <= MAX_REPEATS
        ):
            raise ValueError(f"repeats must be an int in 1..{MAX_REPEATS} (MAX_REPEATS), got {self.repeats!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative int, got {self.seed!r}")
        if self.odometry not in ("map", "robot", "log"):
            raise ValueError(f"odometry must be 'map', 'robot' or 'log', got {self.odometry!r}")
        methods = tuple(dict.fromkeys(self.methods))
        if not methods or any(m not in EVALUATION_METHODS for m in methods):
            raise ValueError(f"methods must be among {EVALUATION_METHODS}, got {self.methods!r}")
        object.__setattr__(self, "methods", methods)
        if self.log_noise is not None:
            noise_model(self.log_noise)

    @property
    def models(self) -> tuple[int, ...]:
        """The noise models run: the settings' ones, or :data:`LOG_NOISE_MODEL` for the log's odometry."""
        return (LOG_NOISE_MODEL,) if self.odometry == "log" else self.noise_models

    def repeats_of(self, model: int) -> int:
        """Noise draws for ``model``: 1 for the noise-free model 0 and for the log, else ``repeats``."""
        if model == LOG_NOISE_MODEL:
            return 1
        noise = NOISE_MODELS[model]
        return 1 if noise.distance_std == 0 and noise.heading_std == 0 else int(self.repeats)


def _unique_ints(values: Iterable[int], name: str, least: int) -> tuple[int, ...]:
    out = []
    for value in values:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be integers, got {value!r}")
        if value < least:
            raise ValueError(f"{name} must be >= {least}, got {value}")
        if int(value) not in out:
            out.append(int(value))
    if not out:
        raise ValueError(f"{name} needs at least one value")
    return tuple(out)


@dataclass(frozen=True)
class QueryMatches:
    """A query traverse matched against a map once: what every configuration reuses.

    Attributes:
        name: the query's name in the outputs (e.g. its folder name).
        images: the N frame names.
        positions: ``(N, 2)`` true positions; ``headings``: ``(N,)`` or None.
        results: N :class:`~nightloc.MatchResult` (scores against every reference, headings).
        tables: ``(N, n_refs, n_shifts)`` float32, every frame's whole rotational SAD table (the
            filter's measurement), or None when not computed.
        odometry: the query's own odometry (N motions, element 0 None), or None.
    """

    name: str
    images: tuple[str, ...]
    positions: np.ndarray
    headings: np.ndarray | None
    results: tuple[MatchResult, ...]
    tables: np.ndarray | None = None
    odometry: tuple | None = None


#: Largest rotational tables :func:`match_traverse` keeps (bytes): frames x references x shifts x 4.
MAX_TABLE_BYTES = 2 << 30


def match_traverse(
    ref_map: ReferenceMap,
    query: Traverse | PathLike,
    name: str | None = None,
    threads: int | None = None,
    *,
    tables: bool = False,
    odometry: bool | PathLike = False,
    filter_params: FilterParams | None = None,
) -> QueryMatches:
    """Prepares every frame of ``query`` with the map's parameters and matches it against the map.

    Args:
        tables: also keep every frame's whole rotational table (what the filter needs; 4 bytes per
            frame x reference x shift).
        odometry: also read the query's own odometry: True for ``<query>/odometry.csv``, or the
            CSV's path.
        filter_params: the filter's parameters the tables are for (default its defaults): a
            forward camera's column window and the row window (``table_window``).

    Raises:
        DatasetError: the query has no poses (ground truth is needed to evaluate), or the
            requested odometry file is missing or does not fit the frames.
    """
    traverse = query if isinstance(query, Traverse) else load_traverse(query)
    if traverse.positions is None:
        raise DatasetError(
            f"query traverse {traverse.root} has no poses; evaluation needs the true position of every frame "
            f"(poses.csv with columns image,x,y[,heading])"
        )
    log = None
    if odometry is not False:
        log = tuple(traverse_odometry(traverse, None if odometry is True else odometry))
    prepared = Preparer(ref_map.params).prepare(traverse)
    if prepared.ndim == 2:
        prepared = prepared[np.newaxis]
    scores, shifts = difference_matrix(prepared, ref_map.images, shifts=ref_map.params.shifts, threads=threads)
    table_array = None
    if tables:
        n_shifts = len(ref_map.params.shifts) if ref_map.params.shifts is not None else ref_map.params.width
        # the filter's translation window: a forward camera's column offsets, row offsets
        window = table_window(
            ref_map.params.width, n_shifts, ref_map.headings is not None, filter_params or FilterParams()
        )
        columns = 2 * window[0] + 1 if window[0] else n_shifts
        size = len(prepared) * len(ref_map) * columns * 4
        if size > MAX_TABLE_BYTES:
            raise ValueError(
                f"the filter's rotational tables of {len(prepared)} frames x {len(ref_map)} references would take "
                f"{size / 2**30:.1f} GB (at most {MAX_TABLE_BYTES / 2**30:.0f}); evaluate fewer frames (frame_step)"
            )
        if window == (0, 0):
            table_array = np.stack(
                [rotational_sad(q, ref_map.images, shifts=ref_map.params.shifts, threads=threads) for q in prepared]
            )
        else:
            table_array = np.stack(
                [shift_table(q, ref_map.images, ref_map.params.shifts, threads, window).scores for q in prepared]
            )
    width = ref_map.params.width
    results = tuple(
        MatchResult(int(np.argmin(scores[i])), scores[i], shifts[i], shifts_to_headings(shifts[i], width), width)
        for i in range(len(prepared))
    )
    return QueryMatches(
        name=name if name is not None else traverse.root.name,
        images=tuple(traverse.names),
        positions=np.asarray(traverse.positions, dtype=np.float64),
        headings=None if traverse.headings is None else np.asarray(traverse.headings, dtype=np.float64),
        results=results,
        tables=table_array,
        odometry=log,
    )


def map_alignment(
    ref_map: ReferenceMap, survey: Traverse | PathLike | None = None
) -> tuple[RigidTransform2D, str] | None:
    """How a map built by a teach run sits in the survey frame of the queries' ``poses.csv``.

    A surveyed map shares the queries' frame: None. A teach run's map lives in its day drive's
    odometry frame; the survey of that drive (``survey``, default the map's source traverse when
    its ``poses.csv`` still lists every map frame) gives the best rigid 2D fit of the map's
    positions onto the surveyed ones (the fit behind the map's ATE).

    Returns:
        ``(transform, description)``: a :class:`~nightloc.mapping.RigidTransform2D` from the
        map frame to the survey frame, and one line saying what was fitted.

    Raises:
        DatasetError: the map is not surveyed and no survey of its frames can be found.
    """
    if ref_map.pose_source == "surveyed":
        return None
    from ..mapping.alignment import absolute_trajectory_error, rigid_fit

    where = survey if survey is not None else (ref_map.source or None)
    traverse = None
    if where is not None:
        try:
            traverse = where if isinstance(where, Traverse) else load_traverse(where)
        except (DatasetError, OSError, ValueError):
            if survey is not None:
                raise
    lookup = {} if traverse is None or traverse.positions is None else dict(zip(traverse.names, traverse.positions))
    if any(name not in lookup for name in ref_map.names):
        raise DatasetError(
            f"the map's poses are {ref_map.pose_source} in its day drive's odometry frame, the query's in its survey "
            f"frame; aligning them needs the survey of the day drive (its poses.csv), which "
            f"{'the map source ' + repr(ref_map.source) + ' lacks' if ref_map.source else 'the map does not name'}: "
            f"give the day traverse with its poses.csv"
        )
    surveyed = np.array([lookup[name] for name in ref_map.names])
    transform = rigid_fit(ref_map.positions, surveyed)
    ate = absolute_trajectory_error(ref_map.positions, surveyed)
    root = traverse.root if traverse is not None else ""
    return transform, (
        f"the map's poses are {ref_map.pose_source} (its day drive's odometry frame): the query's poses are "
        f"compared in that frame after the best rigid 2D fit of the map onto {root}/poses.csv "
        f"(map ATE {ate:.3f} m)"
    )


def align_to_map(matches: QueryMatches, transform: RigidTransform2D) -> QueryMatches:
    """``matches`` with its true poses moved into a teach run's map frame (``transform``: map
    frame to survey frame, from :func:`map_alignment`)."""
    inverse = transform.inverse()
    headings = None if matches.headings is None else inverse.apply_headings(matches.headings)
    return dataclasses.replace(matches, positions=inverse.apply(matches.positions), headings=headings)


def simulated_odometry(matches: QueryMatches, model: int, repeat: int, settings: EvaluationSettings) -> list[object]:
    """The odometry fed to the localizer for each query frame (element 0 is None: no previous frame):
    simulated from the ground truth with noise model ``model`` and draw ``repeat``, or the query's
    own log (``settings.odometry == "log"``)."""
    if settings.odometry == "log":
        if matches.odometry is None:
            raise DatasetError(
                f"query {matches.name} was matched without its odometry log: match_traverse(..., odometry=True) reads "
                f"<query>/odometry.csv"
            )
        return [None, *matches.odometry[1:]]
    rng = np.random.default_rng([settings.seed, model, repeat])
    if settings.odometry == "robot":
        if matches.headings is None:
            raise DatasetError(
                f"query {matches.name} has no headings: robot-frame odometry needs them (use odometry 'map')"
            )
        motions: list[object] = list(simulate_robot_odometry(matches.positions, matches.headings, model, rng))
    else:
        motions = [tuple(step) for step in simulate_map_odometry(matches.positions, model, rng)]
    motions[0] = None
    return motions


def replay(
    ref_map: ReferenceMap,
    matches: QueryMatches,
    frame: int,
    seq_len: int,
    interpolation: bool = True,
    noise: int = 0,
    repeat: int = 0,
    settings: EvaluationSettings | None = None,
    params: LocalizationParams | None = None,
) -> Estimate:
    """The estimate (with heat maps) for one query frame of one configuration, as :func:`evaluate`
    computed it: the localizer runs from the start of the traverse up to ``frame``."""
    settings = settings or EvaluationSettings()
    if not 0 <= frame < len(matches.results):
        raise ValueError(f"frame must be in 0..{len(matches.results) - 1}, got {frame}")
    loc = Localizer(ref_map, params, method="paper", seq_len=seq_len, interpolation=interpolation)
    odometry = simulated_odometry(matches, noise, repeat, settings)
    for i in range(frame):
        loc.update_match(matches.results[i], odometry[i])
    return loc.update_match(matches.results[frame], odometry[frame], return_heatmap=True)


@dataclass(frozen=True)
class SummaryRow:
    """Distance-error statistics of one configuration (metres); the filter's have seq_len 0. One
    field per column of :data:`SUMMARY_COLUMNS`, by its name."""

    seq_len: int
    noise_model: int
    interpolation: bool
    n: int
    median_m: float
    mean_m: float
    p90_m: float
    p95_m: float = math.nan
    share_over_1m: float = math.nan
    longest_run_over_1m: int = 0
    method: str = "paper"


class Evaluation:
    """Per-frame results of :func:`evaluate` (columns of :data:`ERRORS_HEADER` as arrays).

    Attributes:
        columns: name -> ``(rows,)`` array; ``interpolation`` is bool.
        settings: the :class:`EvaluationSettings` used.
        matches: the :class:`QueryMatches` of each query evaluated (for figures and replays).
    """

    def __init__(self, columns: dict[str, np.ndarray], settings: EvaluationSettings, matches: Sequence[QueryMatches]):
        missing = [c for c in ERRORS_HEADER if c not in columns]
        if missing:
            raise ValueError(f"columns missing: {missing}")
        lengths = {len(columns[c]) for c in ERRORS_HEADER}
        if len(lengths) != 1:
            raise ValueError("columns must have equal lengths")
        self.columns = {c: np.asarray(columns[c]) for c in ERRORS_HEADER}
        self.settings = settings
        self.matches = tuple(matches)
        self._frames: np.ndarray | None = None  # frame_index(), computed once for the tail

    def __len__(self) -> int:
        return len(self.columns["error_m"])

    @staticmethod
    def concatenate(parts: Sequence[Evaluation]) -> Evaluation:
        """One evaluation of several queries (same settings)."""
        if not parts:
            raise ValueError("nothing to concatenate")
        columns = {c: np.concatenate([p.columns[c] for p in parts]) for c in ERRORS_HEADER}
        return Evaluation(columns, parts[0].settings, [m for p in parts for m in p.matches])

    def select(
        self,
        seq_len: int | None = None,
        noise_model: int | None = None,
        interpolation: bool | None = None,
        query: str | None = None,
        method: str | None = None,
    ) -> np.ndarray:
        """Boolean row mask of the rows matching every given value."""
        mask = np.ones(len(self), dtype=bool)
        for column, value in (
            ("seq_len", seq_len),
            ("noise_model", noise_model),
            ("interpolation", interpolation),
            ("query", query),
            ("method", method),
        ):
            if value is not None:
                mask &= self.columns[column] == value
        return mask

    def subset(self, method: str) -> Evaluation:
        """The rows of one method (``"paper"`` or ``"filter"``) as an Evaluation."""
        mask = self.select(method=method)
        return Evaluation({c: v[mask] for c, v in self.columns.items()}, self.settings, self.matches)

    def errors(self, **selection) -> np.ndarray:
        """Distance errors (metres) of the rows matching ``selection`` (see :meth:`select`)."""
        return self.columns["error_m"][self.select(**selection)]

    def median(self, **selection) -> float:
        """Median distance error (metres) of the selected rows; NaN if none."""
        errors = self.errors(**selection)
        return float(np.median(errors)) if errors.size else math.nan

    def summary(self, query: str | None = None) -> list[SummaryRow]:
        """Statistics per (seq_len, noise_model, interpolation) of the paper's rows, in the
        settings' order, then per (noise_model, interpolation) of the filter's (seq_len 0)."""
        rows = []

        def add(mask: np.ndarray, n: int, model: int, interp: bool, method: str) -> None:
            e = self.columns["error_m"][mask]
            if e.size:
                tail = self.tail(mask)
                rows.append(
                    SummaryRow(
                        seq_len=n,
                        noise_model=model,
                        interpolation=interp,
                        n=int(e.size),
                        median_m=float(np.median(e)),
                        mean_m=float(e.mean()),
                        p90_m=float(np.percentile(e, 90)),
                        p95_m=tail.p95_m,
                        share_over_1m=tail.share_over_1m,
                        longest_run_over_1m=tail.longest_run_over_1m,
                        method=method,
                    )
                )

        for n in self.settings.seq_lengths:
            for model in self.settings.models:
                for interp in self.settings.interpolation:
                    mask = self.select(seq_len=n, noise_model=model, interpolation=interp, query=query, method="paper")
                    add(mask, n, model, interp, "paper")
        for model in self.settings.models:
            for interp in self.settings.interpolation:
                mask = self.select(noise_model=model, interpolation=interp, query=query, method="filter")
                add(mask, 0, model, interp, "filter")
        return rows

    def runs(self, mask: np.ndarray) -> list[np.ndarray]:
        """The selected rows' errors split into runs (one per query and draw), each in frame order."""
        if self._frames is None:
            self._frames = self.frame_index()
        frames = self._frames
        out = []
        queries, repeats = self.columns["query"][mask], self.columns["repeat"][mask]
        errors, order = self.columns["error_m"][mask], frames[mask]
        for name in dict.fromkeys(queries.tolist()):
            for repeat in dict.fromkeys(repeats[queries == name].tolist()):
                rows = (queries == name) & (repeats == repeat)
                out.append(errors[rows][np.argsort(order[rows], kind="stable")])
        return out

    def tail(self, mask: np.ndarray, first_frame: int = FIRST_FRAME) -> TailMetrics:
        """:func:`~nightloc.localization.tail.tail_metrics` of the selected rows (a boolean mask
        from :meth:`select`), over each run's frames from the ``first_frame``-th on."""
        return tail_metrics(self.runs(mask), first_frame=first_frame)

    def write_errors_csv(self, path: PathLike) -> Path:
        """Writes ``errors.csv`` (header :data:`ERRORS_HEADER`) atomically."""
        c = self.columns
        with atomic_file(path, "w", newline="") as stream:
            writer = csv.writer(stream, lineterminator="\n")
            writer.writerow(ERRORS_HEADER)
            for i in range(len(self)):
                writer.writerow([write(c[name][i]) for name, write in ERRORS_COLUMNS.items()])
        return Path(path)

    def write_summary_csv(self, path: PathLike, query: str | None = None) -> Path:
        """Writes ``summary.csv`` (header :data:`SUMMARY_HEADER`) atomically."""
        with atomic_file(path, "w", newline="") as stream:
            writer = csv.writer(stream, lineterminator="\n")
            writer.writerow(SUMMARY_HEADER)
            for row in self.summary(query):
                writer.writerow([write(getattr(row, name)) for name, write in SUMMARY_COLUMNS.items()])
        return Path(path)

    def table(self, query: str | None = None, interpolation: bool = True, off_column: bool = False) -> str:
        """Median error (m) by sequence length (rows) and noise model (columns), as text.

        ``off_column`` adds a last column with interpolation off at the first noise model (when
        it was evaluated).
        """
        models = self.settings.models
        extra = off_column and False in self.settings.interpolation and interpolation
        header = f"{'n':>3} | " + " | ".join("log odom." if m == LOG_NOISE_MODEL else f"noise {m}" for m in models)
        if extra:
            header += f" | no interp. (noise {models[0]})"
        lines = [header, "-" * len(header)]
        for n in self.settings.seq_lengths:
            cells = [
                self.median(seq_len=n, noise_model=m, interpolation=interpolation, query=query, method="paper")
                for m in models
            ]
            line = f"{n:>3} | " + " | ".join(f"{v:7.2f}" for v in cells)
            if extra:
                off = self.median(seq_len=n, noise_model=models[0], interpolation=False, query=query, method="paper")
                line += f" | {off:7.2f}"
            lines.append(line)
        return "\n".join(lines)

    def frame_index(self) -> np.ndarray:
        """``(rows,)`` int: each row's frame index within its query traverse (0-based)."""
        index = np.zeros(len(self), dtype=int)
        for m in self.matches:
            rows = self.columns["query"] == m.name
            lookup = {image: k for k, image in enumerate(m.images)}
            index[rows] = [lookup[i] for i in self.columns["image"][rows]]
        return index

    def compare_table(self, query: str | None = None, first_frame: int = 10, seq_len: int = 10) -> str:
        """Per noise model, the paper's method at ``seq_len`` beside the filter, both over the query
        frames from the ``first_frame``-th on (the filter's first frames start from nothing, the
        paper's from short sequences): the median and the tail (p95 in metres, the share of frames
        over 1 m, the longest run of them; :func:`~nightloc.localization.tail.tail_metrics`)."""
        columns = (f"paper n={seq_len}: median, p95, > 1 m, run", "filter: median, p95, > 1 m, run")
        header = "noise | " + " | ".join(columns)
        lines = [header, "-" * len(header)]

        def cell(mask: np.ndarray) -> str:
            tail = self.tail(mask, first_frame)
            if tail.n == 0:
                return f"{'-':>27}"
            return (
                f"{tail.median_m:6.2f} {tail.p95_m:6.2f} {100 * tail.share_over_1m:5.1f} % "
                f"{tail.longest_run_over_1m:4d}"
            )

        for model in self.settings.models:
            paper = self.select(seq_len=seq_len, noise_model=model, interpolation=True, query=query, method="paper")
            filt = self.select(noise_model=model, interpolation=True, query=query, method="filter")
            label = "log" if model == LOG_NOISE_MODEL else str(model)
            lines.append(f"{label:>5} | {cell(paper):>{len(columns[0])}} | {cell(filt):>{len(columns[1])}}")
        return "\n".join(lines)


class _ErrorRows:
    """The errors table's columns (``ERRORS_HEADER``) as lists of per-run arrays, one run of
    ``matches``' frames at a time (:meth:`add`)."""

    def __init__(self, matches: QueryMatches):
        self.matches = matches
        self.columns: dict[str, list[np.ndarray]] = {c: [] for c in ERRORS_HEADER}
        self.images = np.array(matches.images, dtype=object)
        self.query_names = np.full(len(matches.results), matches.name, dtype=object)

    def add(self, estimates: list[Estimate], seq_len: np.ndarray, model: int, interp: bool, repeat: int, method: str):
        """One run's estimates (one per frame) with its configuration."""
        rows, truth, n_frames = self.columns, self.matches.positions, len(self.matches.results)
        x = np.array([e.x for e in estimates])
        y = np.array([e.y for e in estimates])
        rows["query"].append(self.query_names)
        rows["image"].append(self.images)
        rows["seq_len"].append(seq_len)
        rows["noise_model"].append(np.full(n_frames, model))
        rows["interpolation"].append(np.full(n_frames, interp))
        rows["repeat"].append(np.full(n_frames, repeat))
        rows["x_est"].append(x)
        rows["y_est"].append(y)
        rows["x_true"].append(truth[:, 0])
        rows["y_true"].append(truth[:, 1])
        rows["error_m"].append(np.hypot(x - truth[:, 0], y - truth[:, 1]))
        rows["ref_index"].append(np.array([e.ref_index for e in estimates]))
        rows["method"].append(np.full(n_frames, method, dtype=object))


def _checked_matches(
    ref_map: ReferenceMap,
    query: Traverse | PathLike | QueryMatches,
    settings: EvaluationSettings,
    name: str | None,
    threads: int | None,
    filter_params: FilterParams | None,
) -> QueryMatches:
    """The query's matches (made here unless given), checked to hold what ``settings`` needs: the
    rotational tables for the filter, headings for robot-frame odometry, the log's odometry."""
    want_tables = "filter" in settings.methods
    want_log = settings.odometry == "log"
    if isinstance(query, QueryMatches):
        matches = query
        if want_tables and matches.tables is None:
            raise ValueError("the filter needs the rotational tables: match_traverse(..., tables=True)")
    else:
        matches = match_traverse(
            ref_map, query, name, threads, tables=want_tables, odometry=want_log, filter_params=filter_params
        )
    if name is not None and isinstance(query, QueryMatches):
        matches = dataclasses.replace(matches, name=name)
    if settings.odometry == "robot" and matches.headings is None:
        raise DatasetError(f"query {matches.name} has no headings: robot-frame odometry needs them")
    if settings.odometry == "robot" and ref_map.headings is None:
        raise DatasetError("the reference map has no headings: robot-frame odometry needs them")
    if want_log and matches.odometry is None:
        raise DatasetError(f"query {matches.name} has no odometry log (match_traverse(..., odometry=True))")
    return matches


def _configurations(settings: EvaluationSettings, draws: list[tuple[int, int]]) -> list[tuple]:
    """The runs of an evaluation, in order: ``(method, interpolation, noise model, repeat, n)``
    (the paper's method per sequence length n, the filter once with n = 0)."""
    work: list[tuple] = []
    if "paper" in settings.methods:
        work += [
            ("paper", interp, model, repeat, n)
            for interp in settings.interpolation
            for model, repeat in draws
            for n in settings.seq_lengths
        ]
    if "filter" in settings.methods:
        work += [("filter", interp, model, repeat, 0) for interp in settings.interpolation for model, repeat in draws]
    return work


def evaluate(
    ref_map: ReferenceMap,
    query: Traverse | PathLike | QueryMatches,
    settings: EvaluationSettings | None = None,
    params: LocalizationParams | None = None,
    name: str | None = None,
    threads: int | None = None,
    progress_desc: str | None = None,
    filter_params: FilterParams | None = None,
) -> Evaluation:
    """Localizes every frame of ``query`` under every configuration of ``settings``.

    Args:
        ref_map: the reference map.
        query: a traverse with poses (folder path or :class:`Traverse`), or the
            :class:`QueryMatches` of an earlier :func:`match_traverse`.
        settings: configurations (default: n = 1..10, noise 0-3, interpolation on and off).
        params: localization parameters (grid, margin, ...); ``seq_len`` and ``interpolation``
            are set per configuration.
        name: the query's name in the ``query`` column (default its folder name).
        threads: matching threads (default all cores).
        progress_desc: progress-bar label (default "evaluating <name>").
        filter_params: the filter's :class:`~nightloc.localization.grid_filter.FilterParams`
            (default its defaults).

    Returns:
        :class:`Evaluation`.
    """
    settings = settings or EvaluationSettings()
    params = params or LocalizationParams()
    if not isinstance(ref_map, ReferenceMap):
        raise TypeError(f"ref_map must be a nightloc.ReferenceMap, got {type(ref_map).__name__}")
    matches = _checked_matches(ref_map, query, settings, name, threads, filter_params)
    n_frames = len(matches.results)
    draws = [(model, repeat) for model in settings.models for repeat in range(settings.repeats_of(model))]
    odometry_cache: dict[tuple[int, int], list[object]] = {}

    def odometry_of(model: int, repeat: int) -> list[object]:
        if (model, repeat) not in odometry_cache:
            odometry_cache[(model, repeat)] = simulated_odometry(matches, model, repeat, settings)
        return odometry_cache[(model, repeat)]

    rows = _ErrorRows(matches)
    record = rows.add

    work = _configurations(settings, draws)
    # one localizer per method and interpolation setting; each configuration starts a fresh copy
    # sharing its grid and weights
    bases = {
        (method, interp): Localizer(ref_map, params, method=method, filter_params=filter_params, interpolation=interp)
        for method in settings.methods
        for interp in settings.interpolation
    }
    desc = progress_desc or f"evaluating {matches.name}"
    for method, interp, model, repeat, n in progress(work, total=len(work), desc=desc, unit="config"):
        odometry = odometry_of(model, repeat)
        if method == "paper":
            loc = bases["paper", interp].with_seq_len(n)
            estimates = [loc.update_match(result, odometry[i]) for i, result in enumerate(matches.results)]
            record(estimates, np.full(n_frames, n), model, interp, repeat, "paper")
        else:
            tables = matches.tables
            if tables is None:  # checked above, or match_traverse(..., tables=True)
                raise ValueError("the filter needs the rotational tables: match_traverse(..., tables=True)")
            loc = bases["filter", interp].fresh()
            if model != LOG_NOISE_MODEL:
                loc.noise = model
            else:
                loc.noise = log_noise_model(odometry) if settings.log_noise is None else settings.log_noise
            estimates = [loc.update_table(tables[i], odometry[i]) for i in range(n_frames)]
            record(estimates, np.arange(1, n_frames + 1), model, interp, repeat, "filter")
    columns = {c: np.concatenate(v) if v else np.zeros(0) for c, v in rows.columns.items()}
    return Evaluation(columns, settings, [matches])
