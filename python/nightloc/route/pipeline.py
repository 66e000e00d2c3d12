"""Route mode in batch: difference matrix, contrast enhancement, then the route filter (default)
or SeqSLAM's trajectory search.

Orientation: matrices are ``(n_query, n_ref)`` float32, row = query, column = reference (like
``scipy.spatial.distance.cdist``; OpenSeqSLAM stores the transpose), lower = more similar.
Matches are 0-based positions in each traverse's order: ``refs[q]`` is the reference matched to
query ``q`` (-1 where undefined) and ``scores[q]`` its score, lower = more confident: for the
filter ``1 - confidence`` (:mod:`nightloc.route.filter`), for SeqSLAM the uniqueness ratio (best
trajectory sum / best sum outside the uniqueness window; NaN where undefined). Every heavy step
runs in the compiled core with the GIL released; Python loops only over blocks of rows (for the
progress bar), never over queries.

Memory: the two ``(n_query, n_ref)`` float32 matrices (the difference matrix and the enhanced
one; ``keep_difference=False`` enhances in place and holds one) plus a scratch block of about
4 MB.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union

import numpy as np

from .. import _core
from .._validate import same_image_size, shift_list, thread_count, uint8_array
from ..io.traverse import Traverse, load_traverse
from ..preparation.params import PreparationParams
from ..progress import progress
from .filter import route_filter_run, texture_weights
from .odometry import carried_odometry, motion_plan
from .params import RouteParams, resolve_params
from .preparation import RoutePreparer
from .speed_check import SpeedCheck, StretchSampler, check_speed

__all__ = [
    "RouteResult",
    "block_rows",
    "enhance_contrast",
    "match_difference",
    "match_prepared",
    "match_route",
    "route_difference_matrix",
    "trajectory_search",
]

#: Cells per block of rows processed at once (progress granularity and scratch memory).
BLOCK_CELLS = 1 << 20

TraverseInput = Union[Traverse, str, "os.PathLike[str]", np.ndarray, Iterable[np.ndarray]]


@dataclass
class RouteResult:
    """Matches of a query traverse against a reference traverse.

    Attributes:
        refs: ``(n_query,)`` int64 matched reference per query, -1 where undefined (SeqSLAM: the
            first and last ds/2 queries in centred mode, the first ds-1 in causal mode; the
            filter answers every query).
        scores: ``(n_query,)`` float64, lower = more confident: ``1 - confidence`` (filter) or
            the uniqueness ratio (SeqSLAM); NaN where undefined.
        enhanced: ``(n_query, n_ref)`` float32 contrast-enhanced difference matrix.
        difference: ``(n_query, n_ref)`` float32 difference matrix, or None when it was
            enhanced in place.
        params: the parameters used (``params.method`` says which search ran).
        timings: seconds per stage (``difference``, ``enhancement``, ``search`` (the filter or
            the trajectory search), ``speed_check``, and ``preparation`` when :func:`match_route`
            prepared the images; a run on a Dask cluster: ``total``).
        confidence: filter only, ``(n_query,)`` float64 belief within ``filter_window`` of the
            match; None for SeqSLAM.
        off_route: filter only, ``(n_query,)`` float64 probability that the query shows no
            reference; None for SeqSLAM.
        weights: filter only, ``(n_query,)`` float64 evidence weight of each query frame (its
            texture), or None.
        motion: filter only: the motion model that ran (a name of
            :data:`~nightloc.route.params.MOTION_MODELS`); None for SeqSLAM.
        speed: filter only, ``(n_query,)`` float64 references per query frame: the speed
            model's mean speed, the odometry model's mean advance; NaN for the window model.
        motion_note: why that motion model ran (e.g. odometry in one traverse only), or "".
        speed_check: the query's speed ratio beside the range the search assumes
            (:mod:`nightloc.route.speed_check`), or None when not checked.
        matrix_image: the enhanced matrix area-averaged for a figure
            (:mod:`nightloc.route.preview`) when the matrix was never held whole (a run on a
            Dask cluster), else None.
    """

    refs: np.ndarray
    scores: np.ndarray
    enhanced: np.ndarray
    difference: np.ndarray | None
    params: RouteParams
    timings: dict[str, float] = field(default_factory=dict)
    confidence: np.ndarray | None = None
    off_route: np.ndarray | None = None
    weights: np.ndarray | None = None
    motion: str | None = None
    speed: np.ndarray | None = None
    motion_note: str = ""
    speed_check: SpeedCheck | None = None
    matrix_image: np.ndarray | None = None

    @property
    def method(self) -> str:
        """``"filter"`` or ``"seqslam"``."""
        return self.params.method

    @property
    def n_queries(self) -> int:
        """Number of query frames."""
        return int(self.refs.shape[0])

    @property
    def n_refs(self) -> int:
        """Number of reference frames."""
        return int(self.enhanced.shape[1])

    @property
    def defined(self) -> np.ndarray:
        """``(n_query,)`` bool: queries with a match."""
        return self.refs >= 0

    def motion_words(self) -> str:
        """The filter's motion model as it ran, with the speeds it used ("speed motion model
        0.5..1.5", "speed window 0.8..1.2", "odometry motion model"); "" for SeqSLAM."""
        if self.method != "filter":
            return ""
        p = self.params
        motion = self.motion or p.filter_motion
        speeds = {  # the models that run at set speeds
            "speed": f"speed motion model {p.filter_speed_min:g}..{p.filter_speed_max:g}",
            "window": f"speed window {p.vmin:g}..{p.vmax:g}",
        }
        return speeds.get(motion, f"{motion} motion model")

    def confidence_at(self, score: float) -> float | None:
        """The filter's confidence at a score threshold: its scores are ``1 - confidence``, so the
        matches of ``score <= t`` are those of ``confidence >= 1 - t``. None for SeqSLAM (its
        scores are uniqueness ratios) or a threshold that is not finite."""
        if self.method != "filter" or not np.isfinite(score):
            return None
        return 1.0 - float(score)


def block_rows(n_cols: int, cells: int = BLOCK_CELLS) -> int:
    """Rows per block so that a block holds about ``cells`` cells (at least 8 rows)."""
    return max(8, cells // max(1, n_cols))


def _checked_matrix(matrix: object, name: str) -> np.ndarray:
    if not isinstance(matrix, np.ndarray):
        raise TypeError(f"{name} must be a numpy.ndarray of dtype float32, got {type(matrix).__name__}")
    if matrix.dtype != np.float32:
        raise TypeError(f"{name} must have dtype float32, got {matrix.dtype} (use matrix.astype(numpy.float32))")
    if matrix.ndim != 2 or 0 in matrix.shape:
        raise ValueError(f"{name} must be a non-empty 2-D (n_query, n_ref) matrix, got shape {matrix.shape}")
    if not matrix.flags.c_contiguous:
        raise ValueError(f"{name} must be C-contiguous; pass numpy.ascontiguousarray({name})")
    return matrix


def _checked_out(out: np.ndarray | None, shape: tuple[int, int], name: str = "out") -> np.ndarray:
    if out is None:
        return np.empty(shape, dtype=np.float32)
    _checked_matrix(out, name)
    if out.shape != shape:
        raise ValueError(f"{name} has shape {out.shape}, expected {shape}")
    if not out.flags.writeable:
        raise ValueError(f"{name} must be writable")
    return out


def _divisor(params: RouteParams, refs: np.ndarray) -> float:
    return float(refs.shape[0]) if params.divisor == "references" else float(refs.shape[1] * refs.shape[2])


def route_difference_matrix(
    queries: np.ndarray,
    refs: np.ndarray,
    params: RouteParams | str | None = None,
    threads: int | None = None,
    out: np.ndarray | None = None,
    progress_desc: str = "difference matrix",
) -> np.ndarray:
    """The ``(n_query, n_ref)`` float32 difference matrix of prepared images.

    ``D[q, r] = float32(double(sum |Q_q - R_r|) / divisor)``, minimum over the circular column
    shifts when ``params.circular_shifts``; the divisor is the number of references
    (OpenSeqSLAM, bit-exact with its ``D``) or the number of pixels (``params.divisor``). With a
    translation window (``params.shift_window``) the minimum is over the window's alignments, each
    a sum over the overlap scaled as by the divisor (the mean over the overlap with ``"pixels"``).

    Args:
        queries: ``(M, H, W)`` uint8 prepared query images.
        refs: ``(N, H, W)`` uint8 prepared reference images.
        params: :class:`RouteParams` or a preset name.
        threads: worker threads (None: all cores).
        out: optional preallocated ``(M, N)`` float32 C-contiguous matrix to fill.
    """
    p = resolve_params(params)
    q = uint8_array(queries, 3, "queries")
    r = uint8_array(refs, 3, "refs")
    same_image_size(q, r, "queries", "refs")
    shifts = shift_list(p.shifts, r.shape[2])
    n_threads = thread_count(threads)
    matrix = _checked_out(out, (q.shape[0], r.shape[0]))
    divisor = _divisor(p, r)
    window = p.window_for(r.shape[1], r.shape[2])
    step = block_rows(r.shape[0])
    starts = range(0, q.shape[0], step)
    for start in progress(starts, total=len(starts), desc=progress_desc, unit="block"):
        stop = min(q.shape[0], start + step)
        _core.difference_matrix_into(q[start:stop], r, shifts, n_threads, divisor, matrix[start:stop], window)
    return matrix


def enhance_contrast(
    difference: np.ndarray,
    params: RouteParams | str | None = None,
    threads: int | None = None,
    out: np.ndarray | None = None,
    offset: str | None = None,
) -> np.ndarray:
    """OpenSeqSLAM's local contrast enhancement of a ``(n_query, n_ref)`` float32 matrix.

    For each query row and reference ``i``: the z-score of ``D[q, i]`` among references
    ``i-r .. i+r`` (``r = params.enhance_radius``, clipped at the ends, N-1 standard deviation),
    all in float32 in Octave's order; then the offset: minus the global minimum (centred mode,
    OpenSeqSLAM; NaN ignored) or plus the bound ``2r/sqrt(2r+1)`` of ``|z|`` (causal mode, so a
    frame's values never depend on later frames). A constant window gives NaN (0/0), as in
    OpenSeqSLAM; NaN is ignored by the search.

    Args:
        difference: ``(M, N)`` float32 C-contiguous, N >= 2.
        out: where to write (may be ``difference`` itself: in place); default a new matrix.
        offset: ``"global_min"``, ``"bound"`` or ``"none"``; default from ``params.mode``.
    """
    p = resolve_params(params)
    d = _checked_matrix(difference, "difference")
    if d.shape[1] < 2:
        raise ValueError(f"contrast enhancement needs at least 2 references, got {d.shape[1]}")
    chosen = p.enhance_offset if offset is None else offset
    if chosen not in ("global_min", "bound", "none"):
        raise ValueError(f"offset must be 'global_min', 'bound' or 'none', got {chosen!r}")
    result = _checked_out(out, d.shape)
    n_threads = thread_count(threads)
    step = block_rows(d.shape[1])
    minimum = math.nan
    starts = range(0, d.shape[0], step)
    for start in progress(starts, total=len(starts), desc="contrast enhancement", unit="block"):
        stop = min(d.shape[0], start + step)
        block_offset = "none" if chosen == "global_min" else chosen
        _, _ = _core.enhance_contrast(d[start:stop], p.enhance_radius, block_offset, n_threads, result[start:stop])
        if chosen == "global_min":
            block_min = float(np.fmin.reduce(result[start:stop], axis=None))  # NaN ignored, no copy
            if not math.isnan(block_min):
                minimum = block_min if math.isnan(minimum) else min(minimum, block_min)
    if chosen == "global_min":
        # Octave: DD - min(min(DD)) in float32 (an all-NaN matrix stays NaN).
        np.subtract(result, np.float32(minimum), out=result)
    return result


def trajectory_search(
    enhanced: np.ndarray,
    params: RouteParams | str | None = None,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Straight-line trajectory search over an enhanced ``(n_query, n_ref)`` matrix.

    Centred mode (OpenSeqSLAM): for query q, trajectories over frames q-ds/2 .. q+ds/2 (ds
    rounded up to even) start at every reference s (and at the +inf padding row past the end),
    pass reference ``s + floor(k*v)`` at frame k, for each speed v in (vmin*ds : 1 : vmax*ds)/ds;
    a trajectory's cost is the float32 sequential sum of its cells (+inf past the end); the
    match is ``argmin + ds/2`` and the score the best cost over the best cost outside
    ``argmin +- uniqueness_radius``, divided in double. Causal mode: trajectories over frames
    q-ds+1 .. q end at reference e (``e - floor(j*v)`` j frames before; +inf before the start)
    and the match is e itself.

    Returns:
        ``(refs, scores)``: ``(n_query,)`` int64 (-1 undefined) and float64 (NaN undefined).
    """
    p = resolve_params(params)
    dd = _checked_matrix(enhanced, "enhanced")
    n_threads = thread_count(threads)
    causal = p.mode == "causal"
    refs = np.full(dd.shape[0], -1, dtype=np.int64)
    scores = np.full(dd.shape[0], np.nan)
    step = 256  # queries per call: progress granularity; each call spreads over the threads
    starts = range(0, dd.shape[0], step)
    for start in progress(starts, total=len(starts), desc="trajectory search", unit="block"):
        stop = min(dd.shape[0], start + step)
        block_refs, block_scores = _core.trajectory_search(
            dd, p.ds, p.vmin, p.vmax, p.uniqueness_radius, causal, start, stop, n_threads
        )
        refs[start:stop] = block_refs[start:stop]
        scores[start:stop] = block_scores[start:stop]
    return refs, scores


def match_difference(
    difference: np.ndarray,
    params: RouteParams | str | None = None,
    threads: int | None = None,
    keep_difference: bool = True,
    weights: np.ndarray | None = None,
    *,
    advances: np.ndarray | None = None,
    reference_distances: np.ndarray | None = None,
    carried_odometry: tuple[np.ndarray, np.ndarray] | None = None,
    speed_check: bool = True,
) -> RouteResult:
    """Route matching from a difference matrix: enhancement, then the filter or SeqSLAM.

    Args:
        difference: ``(M, N)`` float32 difference matrix (:func:`route_difference_matrix`).
        params: :class:`RouteParams` or a preset name (default ``"nightloc"``).
        threads: worker threads (None: all cores); the filter's updates run in order on one.
        keep_difference: False enhances ``difference`` in place (``result.difference`` None).
        weights: filter only: ``(M,)`` evidence weights in [0, 1]
            (:func:`~nightloc.route.filter.texture_weights` of the prepared queries); None: 1.
        advances, reference_distances: filter only, both or neither: the odometry model
            (``(M,)`` distance travelled before each query, ``(N,)`` cumulative distance of each
            reference; :mod:`nightloc.route.odometry`); without them the filter runs
            ``params.filter_motion``.
        carried_odometry: ``(advances, reference_distances)`` of traverses that carry odometry
            the search does not use (SeqSLAM, another motion model): the speed check reads it.
        speed_check: measure the query's speed ratio and compare it with the search's range
            (``result.speed_check``, :func:`~nightloc.route.speed_check.check_speed`).
    """
    p = resolve_params(params)
    timings: dict[str, float] = {}
    start = time.perf_counter()
    out = None if keep_difference else difference
    enhanced = enhance_contrast(difference, p, threads, out=out, offset=p.search_offset)
    timings["enhancement"] = time.perf_counter() - start
    start = time.perf_counter()
    confidence = off_route = speed = motion = None
    if p.method == "filter":
        matched, confidence, off_route, speed, motion = route_filter_run(
            enhanced, p, weights, threads, advances, reference_distances
        )
        scores = 1.0 - confidence
    else:
        matched, scores = trajectory_search(enhanced, p, threads)
    timings["search"] = time.perf_counter() - start
    checked = None
    start = time.perf_counter()
    if speed_check:
        odometry = carried_odometry
        if advances is not None and reference_distances is not None:
            odometry = (advances, reference_distances)
        stretches = None
        if odometry is None:
            sampler = StretchSampler(enhanced.shape[0])
            sampler.take(0, enhanced, copy=False)
            stretches = sampler.rows()
        checked = check_speed(p, motion, stretches, odometry)
        timings["speed_check"] = time.perf_counter() - start
    return RouteResult(
        refs=matched,
        scores=scores,
        enhanced=enhanced,
        difference=difference if keep_difference else None,
        params=p,
        timings=timings,
        confidence=confidence,
        off_route=off_route,
        weights=weights if p.method == "filter" else None,
        motion=motion,
        speed=speed,
        speed_check=checked,
    )


def match_prepared(
    refs: np.ndarray,
    queries: np.ndarray,
    params: RouteParams | str | None = None,
    threads: int | None = None,
    keep_difference: bool = True,
    *,
    advances: np.ndarray | None = None,
    reference_distances: np.ndarray | None = None,
    carried_odometry: tuple[np.ndarray, np.ndarray] | None = None,
) -> RouteResult:
    """Route matching of prepared images: difference matrix, enhancement, then the route filter
    (``params.method = "filter"``, the default) or SeqSLAM's trajectory search.

    Args:
        refs: ``(N, H, W)`` uint8 prepared reference images, in route order.
        queries: ``(M, H, W)`` uint8 prepared query images, in route order.
        params: :class:`RouteParams` or a preset name (default ``"nightloc"``).
        threads: worker threads (None: all cores).
        keep_difference: keep the difference matrix (two M x N float32 matrices in memory);
            False enhances it in place (one matrix; ``result.difference`` is None).
        advances, reference_distances: the filter's odometry model (:func:`match_difference`).
        carried_odometry: odometry the search does not use, for the speed check
            (:func:`match_difference`).
    """
    p = resolve_params(params)
    start = time.perf_counter()
    difference = route_difference_matrix(queries, refs, p, threads)
    elapsed = time.perf_counter() - start
    weights = texture_weights(queries, p.filter_min_texture) if p.method == "filter" else None
    result = match_difference(
        difference,
        p,
        threads,
        keep_difference,
        weights,
        advances=advances,
        reference_distances=reference_distances,
        carried_odometry=carried_odometry,
    )
    result.timings = {"difference": elapsed, **result.timings}
    return result


def _as_frames(source: TraverseInput, name: str, frame_step: int) -> Traverse | np.ndarray | Iterable[np.ndarray]:
    if isinstance(source, (str, os.PathLike)):
        return load_traverse(Path(source), frame_step=frame_step)
    if isinstance(source, (Traverse, np.ndarray)):
        return source
    if isinstance(source, Iterable):  # apart from the line above for mypy: str is Iterable too
        return source
    raise TypeError(f"{name} must be a Traverse, a path, or frames, got {type(source).__name__}")


def match_route(
    reference: TraverseInput,
    query: TraverseInput,
    params: RouteParams | str | None = None,
    preparation: PreparationParams | None = None,
    threads: int | None = None,
    keep_difference: bool = True,
    frame_step: int = 1,
    odometry: bool = True,
) -> RouteResult:
    """Route matching from camera frames: prepare both traverses, then :func:`match_prepared`.

    Args:
        reference, query: a :class:`Traverse`, a traverse folder or video path (loaded with
            :func:`nightloc.load_traverse`; order = sorted file names), or frames (a stack or
            an iterable of ``(H, W)`` / ``(H, W, 3)`` BGR images).
        params: :class:`RouteParams` or a preset name (``"openseqslam"``, ``"nightloc"``).
        preparation: :class:`PreparationParams` for the ``"nightloc"`` preparation.
        frame_step: keep every k-th video frame when a path is a video.
        odometry: when both traverses carry odometry (``odometry.csv``, or poses), the filter
            runs its odometry model (:func:`nightloc.route.odometry.motion_plan`); False: never.
            ``result.motion`` and ``result.motion_note`` say what ran and why.
    """
    p = resolve_params(params)
    preparer = RoutePreparer(p, preparation)
    reference_frames = _as_frames(reference, "reference", frame_step)
    query_frames = _as_frames(query, "query", frame_step)
    plan = carried = None
    if isinstance(reference_frames, Traverse) and isinstance(query_frames, Traverse):
        if p.method == "filter":
            plan = motion_plan(reference_frames, query_frames, p.filter_motion, odometry)
        carried = carried_odometry(reference_frames, query_frames)
    start = time.perf_counter()
    refs = preparer(reference_frames)
    queries = preparer(query_frames)
    prep_time = time.perf_counter() - start
    if refs.ndim != 3 or queries.ndim != 3:
        raise ValueError("reference and query must each hold several frames, not a single image")
    result = match_prepared(
        refs,
        queries,
        p,
        threads,
        keep_difference,
        advances=None if plan is None else plan.advances,
        reference_distances=None if plan is None else plan.reference_distances,
        carried_odometry=carried,
    )
    result.timings["preparation"] = prep_time
    if plan is not None:
        result.motion_note = plan.note
    return result
