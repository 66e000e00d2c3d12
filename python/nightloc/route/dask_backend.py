"""Route mode beyond one machine: the pipeline blocked on a Dask cluster (optional).

Install with ``pip install "nightloc[dask]"``. The difference matrix and the contrast
enhancement are independent per query row (the enhancement window runs along the reference
axis), so the queries are cut into blocks of rows and each block becomes one task that compares
it with every reference and enhances it in the compiled core. Only the centred mode's global
minimum needs every block: one small reduction of the block minima. The trajectory search runs
per block too, each task reading its rows plus the ds/2 (centred) or ds-1 (causal) rows its
trajectories reach into the neighbouring blocks. Nothing is gathered on the client except the
matches (two vectors of n_query values); the matrices stay on the workers as Dask arrays.
The route filter (``method="filter"``) is sequential over the queries: the enhanced blocks are
brought to the client one at a time, in order, and the filter continues over each (memory: one
block).

Results are bit-identical to the in-process :func:`~nightloc.route.match_prepared` (the same
kernels on the same rows; the offset is one float32 subtraction or addition per cell either way).

Example::

    from dask.distributed import Client, LocalCluster
    from nightloc.route.dask_backend import dask_match_prepared

    with Client(LocalCluster(n_workers=4)) as client:
        result = dask_match_prepared(refs, queries, "openseqslam", rows_per_block=2000)
    result.refs, result.scores                  # numpy, (n_query,)
    result.enhanced                             # dask array (n_query, n_ref), lazy

**Streaming** (:func:`dask_stream_match`, what ``nightloc route --dask`` runs): on a
``dask.distributed`` client, the references are scattered to every worker once and the query rows
are cut into bands; a bounded number of band tasks is in flight at any time, so memory is bounded
by bands, not by the matrix. The filter receives the enhanced bands in order on the client and
continues over each; SeqSLAM searches each band on its worker with the rows its trajectories reach
beyond the band recomputed there (centred mode first runs a pass of band minima for the global
minimum, so its difference rows are computed twice). Each band also brings its share of the
matrix's picture (:mod:`nightloc.route.preview`) and the rows the speed check samples
(:mod:`nightloc.route.speed_check`); matches, scores and summaries are identical to
:func:`~nightloc.route.match_prepared`'s.

Requirements: the prepared reference images are sent to every worker once (they must fit in a
worker's memory: ``n_ref * H * W`` bytes, 7 MB for 3576 Nordland frames); one block of rows,
``rows_per_block * n_ref * 4`` bytes (twice with ``keep_difference``), must fit in a task.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from .. import _core
from .._validate import same_image_size, shift_list, uint8_array
from ..errors import MissingDependencyError
from .filter import core_params, motion_name, texture_weights
from .params import RouteParams, resolve_params
from .pipeline import RouteResult, _divisor
from .preview import MatrixPreview, PreviewPart, preview_part
from .speed_check import MatchesRatio, StretchSampler, check_speed

__all__ = [
    "BAND_CELLS",
    "dask_available",
    "dask_match_prepared",
    "dask_route_matrices",
    "dask_stream_match",
    "local_client",
    "require_distributed",
]

#: Matrix cells per band of query rows in :func:`dask_stream_match` (float32: 4 MB).
BAND_CELLS = 1 << 20
#: Install command named by the errors.
INSTALL = 'pip install "nightloc[dask]"'


def dask_available() -> bool:
    """True when ``dask`` (with ``dask.array``) can be imported."""
    try:
        import dask
        import dask.array  # noqa: F401
    except ImportError:
        return False
    return True


def _require_dask():
    try:
        import dask
        import dask.array as da
    except ImportError as error:  # pragma: no cover - exercised only without dask
        raise MissingDependencyError(
            f'the Dask backend needs dask: {INSTALL} (or pip install "dask[distributed]")'
        ) from error
    return dask, da


def require_distributed():
    """``dask.distributed``, or MissingDependencyError naming the install command."""
    try:
        import distributed
    except ImportError:
        raise MissingDependencyError(f"running on a Dask cluster needs dask.distributed: {INSTALL}") from None
    return distributed


# --------------------------------------------------------------------------------------------
# tasks (plain functions: they run on the workers)


def _block_task(
    queries: np.ndarray,
    refs: np.ndarray,
    shifts: np.ndarray,
    divisor: float,
    radius: int,
    offset: str,
    keep_difference: bool,
    threads: int,
    window: tuple[int, int] = (0, 0),
) -> tuple[np.ndarray | None, np.ndarray, float]:
    """Difference rows (translation window ``(columns, rows)``) and their enhancement (offset
    ``none`` or ``bound``) for one block; returns (difference or None, enhanced, NaN-ignoring
    minimum of the enhanced block)."""
    difference = np.empty((queries.shape[0], refs.shape[0]), dtype=np.float32)
    _core.difference_matrix_into(queries, refs, shifts, threads, divisor, difference, window)
    out = np.empty_like(difference) if keep_difference else difference
    _core.enhance_contrast(difference, radius, offset, threads, out)
    minimum = float(np.fmin.reduce(out, axis=None))  # NaN ignored (NaN only if all are)
    return (difference if keep_difference else None), out, minimum


def _global_minimum(*minima: float) -> float:
    present = [m for m in minima if not math.isnan(m)]
    return min(present) if present else math.nan


def _subtract(block: np.ndarray, minimum: float) -> np.ndarray:
    # Octave: DD - min(min(DD)), float32; a fresh array (task results must not be mutated).
    return np.subtract(block, np.float32(minimum))


def _search_task(
    pieces: list[np.ndarray], first_row: int, begin: int, end: int, params: RouteParams, threads: int
) -> tuple[np.ndarray, np.ndarray]:
    """Matches of queries [begin, end) from the enhanced rows [first_row, first_row + rows)."""
    window = np.ascontiguousarray(np.concatenate(pieces, axis=0))
    refs, scores = _core.trajectory_search(
        window,
        params.ds,
        params.vmin,
        params.vmax,
        params.uniqueness_radius,
        params.mode == "causal",
        begin - first_row,
        end - first_row,
        threads,
    )
    return refs[begin - first_row : end - first_row], scores[begin - first_row : end - first_row]


# --------------------------------------------------------------------------------------------


def _blocks(n_rows: int, rows_per_block: int) -> list[tuple[int, int]]:
    return [(start, min(n_rows, start + rows_per_block)) for start in range(0, n_rows, rows_per_block)]


def dask_route_matrices(
    refs: np.ndarray,
    queries: np.ndarray,
    params: RouteParams | str | None = None,
    rows_per_block: int = 1024,
    keep_difference: bool = False,
    threads_per_task: int = 1,
):
    """The difference matrix and the enhanced matrix as lazy Dask arrays.

    Args:
        refs: ``(N, H, W)`` uint8 prepared references (sent to the workers once).
        queries: ``(M, H, W)`` uint8 prepared queries, cut into blocks of ``rows_per_block``.
        params: :class:`RouteParams` or a preset name.
        keep_difference: also return the difference matrix (else None).
        threads_per_task: core threads inside one task (Dask runs tasks in parallel).

    Returns:
        ``(difference or None, enhanced, blocks)``: ``(M, N)`` float32 Dask arrays chunked by
        rows, and the list of ``(start, stop)`` row blocks.
    """
    dask, da = _require_dask()
    p = resolve_params(params)
    r = uint8_array(refs, 3, "refs")
    q = uint8_array(queries, 3, "queries")
    same_image_size(q, r, "queries", "refs")
    if r.shape[0] < 2:
        raise ValueError(f"contrast enhancement needs at least 2 references, got {r.shape[0]}")
    if isinstance(rows_per_block, bool) or not isinstance(rows_per_block, (int, np.integer)) or rows_per_block < 1:
        raise ValueError(f"rows_per_block must be an int >= 1, got {rows_per_block!r}")
    shifts = shift_list(p.shifts, r.shape[2])
    divisor = _divisor(p, r)
    block_offset = "none" if p.search_offset == "global_min" else "bound"
    delayed = dask.delayed
    refs_node = delayed(r, pure=True, traverse=False)
    shifts_node = delayed(shifts, pure=True, traverse=False)
    blocks = _blocks(q.shape[0], int(rows_per_block))
    n_refs = r.shape[0]
    tasks = [
        delayed(_block_task, pure=True, nout=3)(
            np.ascontiguousarray(q[start:stop]),
            refs_node,
            shifts_node,
            divisor,
            p.enhance_radius,
            block_offset,
            keep_difference,
            threads_per_task,
            p.window_for(r.shape[1], r.shape[2]),
        )
        for start, stop in blocks
    ]
    if p.search_offset == "global_min":
        minimum = delayed(_global_minimum, pure=True)(*[task[2] for task in tasks])
        enhanced_nodes = [delayed(_subtract, pure=True)(task[1], minimum) for task in tasks]
    else:
        enhanced_nodes = [task[1] for task in tasks]
    enhanced = da.concatenate(
        [
            da.from_delayed(node, shape=(stop - start, n_refs), dtype=np.float32)
            for node, (start, stop) in zip(enhanced_nodes, blocks)
        ],
        axis=0,
    )
    difference = None
    if keep_difference:
        difference = da.concatenate(
            [
                da.from_delayed(task[0], shape=(stop - start, n_refs), dtype=np.float32)
                for task, (start, stop) in zip(tasks, blocks)
            ],
            axis=0,
        )
    return difference, enhanced, blocks


def dask_match_prepared(
    refs: np.ndarray,
    queries: np.ndarray,
    params: RouteParams | str | None = None,
    rows_per_block: int = 1024,
    keep_difference: bool = False,
    threads_per_task: int = 1,
    client: object | None = None,
) -> RouteResult:
    """:func:`~nightloc.route.match_prepared` on a Dask cluster.

    Runs on ``client`` (a ``dask.distributed.Client``) when given, else on Dask's current
    scheduler (the active client, or threads). Returns a :class:`RouteResult` whose ``refs`` and
    ``scores`` are numpy arrays and whose ``enhanced`` (and ``difference`` with
    ``keep_difference``) are lazy Dask arrays; ``timings["total"]`` is the wall time.
    """
    dask, _da = _require_dask()
    p = resolve_params(params)
    if p.method == "filter":
        return _dask_filter(refs, queries, p, rows_per_block, keep_difference, threads_per_task, client)
    n_refs = refs.shape[0] if isinstance(refs, np.ndarray) and refs.ndim == 3 else 0
    needed = 2 * p.uniqueness_radius + (1 if p.mode == "centred" else 2)
    if n_refs and n_refs < needed:
        raise ValueError(
            f"{n_refs} references are too few for a uniqueness window of +-{p.uniqueness_radius} "
            f"(needs at least {needed})"
        )
    start_time = time.perf_counter()
    difference, enhanced, blocks = dask_route_matrices(
        refs, queries, p, rows_per_block, keep_difference, threads_per_task
    )
    plan = _core.trajectory_plan(p.ds, p.vmin, p.vmax, p.uniqueness_radius, p.mode == "causal")
    before, after = -int(plan["columns"][0]), int(plan["columns"][-1])
    n_queries = enhanced.shape[0]
    enhanced_blocks = enhanced.to_delayed().ravel().tolist()
    results = []
    for start, stop in blocks:
        lo, hi = max(0, start - before), min(n_queries, stop + after)
        pieces = []
        for (b0, b1), node in zip(blocks, enhanced_blocks):
            if b1 > lo and b0 < hi:
                pieces.append(node[max(lo, b0) - b0 : min(hi, b1) - b0])
        results.append(dask.delayed(_search_task, pure=True, nout=2)(pieces, lo, start, stop, p, threads_per_task))
    computed = client.compute(results, sync=True) if client is not None else dask.compute(*results)  # type: ignore[attr-defined]
    matched = np.concatenate([pair[0] for pair in computed]).astype(np.int64)
    scores = np.concatenate([pair[1] for pair in computed]).astype(np.float64)
    timings: dict[str, float] = {"total": time.perf_counter() - start_time}
    return RouteResult(refs=matched, scores=scores, enhanced=enhanced, difference=difference, params=p, timings=timings)


def _dask_filter(refs, queries, p, rows_per_block, keep_difference, threads_per_task, client) -> RouteResult:
    dask, _da = _require_dask()
    start_time = time.perf_counter()
    difference, enhanced, blocks = dask_route_matrices(
        refs, queries, p, rows_per_block, keep_difference, threads_per_task
    )
    weights = texture_weights(queries, p.filter_min_texture)
    state = _core.RouteFilter(enhanced.shape[1], core_params(p, motion_name(p, odometry=False)))
    pieces = []
    for node, (start, stop) in zip(enhanced.to_delayed().ravel().tolist(), blocks):
        block = client.compute(node, sync=True) if client is not None else dask.compute(node)[0]
        pieces.append(state.run(np.ascontiguousarray(block), weights[start:stop]))
    matched = np.concatenate([piece[0] for piece in pieces]).astype(np.int64)
    confidence = np.concatenate([piece[1] for piece in pieces])
    off_route = np.concatenate([piece[2] for piece in pieces])
    timings: dict[str, float] = {"total": time.perf_counter() - start_time}
    return RouteResult(
        refs=matched,
        scores=1.0 - confidence,
        enhanced=enhanced,
        difference=difference,
        params=p,
        timings=timings,
        confidence=confidence,
        off_route=off_route,
        weights=weights,
    )


# --------------------------------------------------------------------------------------------
# streaming on a dask.distributed client: bands of query rows, a bounded number in flight


@contextlib.contextmanager
def local_client(workers: int, threads_per_worker: int = 1, processes: bool = True) -> Iterator[Any]:
    """A ``dask.distributed`` client of a new ``LocalCluster`` on loopback (127.0.0.1, TCP, no
    dashboard), for a ``with`` block; the client and the cluster close at its end."""
    distributed = require_distributed()
    with (
        distributed.LocalCluster(
            n_workers=workers,
            threads_per_worker=threads_per_worker,
            processes=processes,
            host="127.0.0.1",
            protocol="tcp://",  # loopback TCP also when the workers are threads of this process
            dashboard_address=":0",  # the scheduler's HTTP server on a free port, without the dashboard
            scheduler_kwargs={"dashboard": False},
            silence_logs=logging.ERROR,
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


def _band_rows(n_refs: int, rows: int | None) -> int:
    """Query rows per band: ``rows``, or ``BAND_CELLS`` cells (at least 8 rows)."""
    if rows is None:
        return max(8, BAND_CELLS // max(1, n_refs))
    if isinstance(rows, bool) or not isinstance(rows, (int, np.integer)) or rows < 1:
        raise ValueError(f"rows_per_band must be an int >= 1, got {rows!r}")
    return int(rows)


def _enhanced_rows(
    queries: np.ndarray,
    refs: np.ndarray,
    shifts: np.ndarray,
    divisor: float,
    radius: int,
    offset: str,
    minimum: float | None,
    threads: int,
    window: tuple[int, int],
) -> np.ndarray:
    """Difference rows of ``queries`` enhanced as the in-process pipeline does (offset ``bound`` or
    ``none``; minus ``minimum`` in float32 when given: the centred mode's global minimum)."""
    rows = np.empty((queries.shape[0], refs.shape[0]), dtype=np.float32)
    _core.difference_matrix_into(queries, refs, shifts, threads, divisor, rows, window)
    _core.enhance_contrast(rows, radius, offset, threads, rows)
    if minimum is not None:
        np.subtract(rows, np.float32(minimum), out=rows)
    return rows


def _stretch_rows(stretches: list[tuple[int, int]], start: int, rows: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """The rows of ``rows`` (query rows ``start ..``) in the speed check's stretches, copied."""
    stop = start + rows.shape[0]
    out = []
    for first, last in stretches:
        lo, hi = max(first, start), min(last, stop)
        if lo < hi:
            out.append((lo, np.array(rows[lo - start : hi - start])))
    return out


def _stream_band_task(
    queries: np.ndarray,
    refs: np.ndarray,
    shifts: np.ndarray,
    divisor: float,
    radius: int,
    offset: str,
    minimum: float | None,
    threads: int,
    window: tuple[int, int],
    start: int,
    n_queries: int,
) -> tuple[np.ndarray, PreviewPart]:
    """One band for the filter: its enhanced rows and their share of the picture."""
    rows = _enhanced_rows(queries, refs, shifts, divisor, radius, offset, minimum, threads, window)
    return rows, preview_part(rows, start, n_queries)


def _minimum_task(
    queries: np.ndarray,
    refs: np.ndarray,
    shifts: np.ndarray,
    divisor: float,
    radius: int,
    threads: int,
    window: tuple[int, int],
) -> float:
    """The NaN-ignoring minimum of one band's enhanced rows before the offset (centred mode)."""
    rows = _enhanced_rows(queries, refs, shifts, divisor, radius, "none", None, threads, window)
    return float(np.fmin.reduce(rows, axis=None))


def _search_band_task(
    queries: np.ndarray,
    refs: np.ndarray,
    shifts: np.ndarray,
    divisor: float,
    radius: int,
    offset: str,
    minimum: float | None,
    threads: int,
    window: tuple[int, int],
    first_row: int,
    start: int,
    stop: int,
    n_queries: int,
    params: RouteParams,
    stretches: list[tuple[int, int]],
) -> tuple[np.ndarray, np.ndarray, PreviewPart, list[tuple[int, np.ndarray]]]:
    """SeqSLAM on one band: ``queries`` are rows ``first_row ..`` (the band and the rows its
    trajectories reach); returns the matches and scores of rows ``start .. stop-1``, the band's
    share of the picture and its rows in the speed check's stretches."""
    rows = _enhanced_rows(queries, refs, shifts, divisor, radius, offset, minimum, threads, window)
    matched, scores = _core.trajectory_search(
        rows,
        params.ds,
        params.vmin,
        params.vmax,
        params.uniqueness_radius,
        params.mode == "causal",
        start - first_row,
        stop - first_row,
        threads,
    )
    band = rows[start - first_row : stop - first_row]
    return (
        matched[start - first_row : stop - first_row],
        scores[start - first_row : stop - first_row],
        preview_part(band, start, n_queries),
        _stretch_rows(stretches, start, band),
    )


def _in_order(submit: Callable[[int], Any], count: int, in_flight: int) -> Iterator[Any]:
    """The results of ``submit(0) .. submit(count - 1)`` (futures) in order, with at most
    ``in_flight`` submitted and not yet consumed."""
    pending: dict[int, Any] = {}
    submitted = 0
    for index in range(count):
        while submitted < count and submitted < index + in_flight:
            pending[submitted] = submit(submitted)
            submitted += 1
        future = pending.pop(index)
        yield future.result()
        future.release()


def _checked_images(
    refs: np.ndarray, queries: np.ndarray, advances: np.ndarray | None, reference_distances: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """The prepared references and queries, checked: uint8 ``(N, H, W)`` and ``(M, H, W)`` of one
    size, at least 2 references, the odometry model's two arrays both or neither."""
    r = uint8_array(refs, 3, "refs")
    q = uint8_array(queries, 3, "queries")
    same_image_size(q, r, "queries", "refs")
    if r.shape[0] < 2:
        raise ValueError(f"contrast enhancement needs at least 2 references, got {r.shape[0]}")
    if (advances is None) != (reference_distances is None):
        raise ValueError("the odometry model needs both advances and reference_distances")
    return r, q


def _checked_in_flight(client: object, in_flight: int | None) -> int:
    """The bands submitted ahead: ``in_flight``, by default twice the cluster's threads."""
    if in_flight is None:
        in_flight = 2 * max(1, sum(client.nthreads().values()))  # type: ignore[attr-defined]
    if isinstance(in_flight, bool) or not isinstance(in_flight, (int, np.integer)) or in_flight < 1:
        raise ValueError(f"in_flight must be an int >= 1, got {in_flight!r}")
    return int(in_flight)


@dataclasses.dataclass
class _Stream:
    """What the bands of one streamed match share: the client, the prepared queries ``(M, H, W)``,
    the bands' ``(lo, hi)`` rows, the tasks' common arguments (the scattered references, shifts,
    divisor, enhancement radius), their threads and window, the bands in flight, and what the
    client gathers: the matrix's picture, the speed check's sampled stretches and their ratios."""

    client: object
    queries: np.ndarray
    blocks: list[tuple[int, int]]
    common: tuple
    threads_per_task: int
    window: object
    in_flight: int
    preview: MatrixPreview
    sampler: StretchSampler | None
    matches: MatchesRatio


def _stream_filter(
    stream: _Stream, state: object, weights: np.ndarray, advances: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The route filter over the streamed bands, in order: matched references ``(M,)`` int64, and
    the confidence, off-route probability and speed per query."""
    q, blocks, n_queries = stream.queries, stream.blocks, stream.queries.shape[0]

    def submit(index: int) -> object:
        lo, hi = blocks[index]
        return stream.client.submit(  # type: ignore[attr-defined]
            _stream_band_task,
            q[lo:hi],
            *stream.common,
            "bound",
            None,
            stream.threads_per_task,
            stream.window,
            lo,
            n_queries,
            pure=False,
        )

    pieces = []
    for (lo, hi), (band, part) in zip(blocks, _in_order(submit, len(blocks), stream.in_flight)):
        step = None if advances is None else np.ascontiguousarray(advances[lo:hi], dtype=np.float64)
        pieces.append(state.run(band, weights[lo:hi], 1, step))  # type: ignore[attr-defined]
        stream.preview.add(part)
        if stream.sampler is not None:
            stream.sampler.take(lo, band)
            for stretch in stream.sampler.complete():
                stream.matches.add(stretch)
        del band
    matched = np.concatenate([piece[0] for piece in pieces]).astype(np.int64)
    return matched, *(np.concatenate([piece[k] for piece in pieces]) for k in (1, 2, 3))  # type: ignore[return-value]


def _stream_search(stream: _Stream, p: RouteParams) -> tuple[np.ndarray, np.ndarray]:
    """SeqSLAM's trajectory search over the streamed bands (each with the rows its trajectories
    reach): matched references ``(M,)`` int64 and scores ``(M,)`` float64."""
    q, blocks, n_queries = stream.queries, stream.blocks, stream.queries.shape[0]
    minimum = None
    offset = "bound" if p.search_offset == "bound" else "none"
    if p.search_offset == "global_min":

        def submit_minimum(index: int) -> object:
            lo, hi = blocks[index]
            return stream.client.submit(  # type: ignore[attr-defined]
                _minimum_task, q[lo:hi], *stream.common, stream.threads_per_task, stream.window, pure=False
            )

        minimum = _global_minimum(*_in_order(submit_minimum, len(blocks), stream.in_flight))
    plan = _core.trajectory_plan(p.ds, p.vmin, p.vmax, p.uniqueness_radius, p.mode == "causal")
    before, after = -int(plan["columns"][0]), int(plan["columns"][-1])
    stretches = [] if stream.sampler is None else stream.sampler.stretches

    def submit_search(index: int) -> object:
        lo, hi = blocks[index]
        first, last = max(0, lo - before), min(n_queries, hi + after)
        return stream.client.submit(  # type: ignore[attr-defined]
            _search_band_task,
            q[first:last],
            *stream.common,
            offset,
            minimum,
            stream.threads_per_task,
            stream.window,
            first,
            lo,
            hi,
            n_queries,
            p,
            stretches,
            pure=False,
        )

    matched_parts, score_parts = [], []
    for band_refs, band_scores, part, sampled in _in_order(submit_search, len(blocks), stream.in_flight):
        matched_parts.append(band_refs)
        score_parts.append(band_scores)
        stream.preview.add(part)
        if stream.sampler is not None:
            for lo, piece in sampled:
                stream.sampler.take(lo, piece, copy=False)
            for stretch in stream.sampler.complete():
                stream.matches.add(stretch)
    return np.concatenate(matched_parts).astype(np.int64), np.concatenate(score_parts).astype(np.float64)


# long: its docstring states the streaming contract (19 lines); the body, 56, sets up the stream and the result
def dask_stream_match(
    client: object,
    refs: np.ndarray,
    queries: np.ndarray,
    params: RouteParams | str | None = None,
    *,
    rows_per_band: int | None = None,
    in_flight: int | None = None,
    threads_per_task: int = 1,
    advances: np.ndarray | None = None,
    reference_distances: np.ndarray | None = None,
    carried_odometry: tuple[np.ndarray, np.ndarray] | None = None,
    speed_check: bool = True,
) -> RouteResult:
    """:func:`~nightloc.route.match_prepared` on a ``dask.distributed`` client, streaming bands of
    query rows (the module docstring says how): identical matches, scores, confidences and speed
    check, with memory bounded by ``in_flight`` bands on the workers and one on the client.

    Args:
        client: a ``dask.distributed.Client`` (e.g. :func:`local_client`).
        refs, queries: ``(N, H, W)`` and ``(M, H, W)`` uint8 prepared images.
        params: :class:`RouteParams` or a preset name.
        rows_per_band: query rows per band (default: ``BAND_CELLS`` cells, at least 8 rows).
        in_flight: bands submitted ahead (default twice the cluster's threads).
        threads_per_task: core threads inside one task.
        advances, reference_distances, carried_odometry, speed_check: as
            :func:`~nightloc.route.match_difference`.

    Returns:
        A :class:`RouteResult` whose ``enhanced`` is the lazy Dask array of
        :func:`dask_route_matrices` (computed again on the cluster if read), ``difference`` None,
        and ``matrix_image`` the enhanced matrix's picture built band by band.
    """
    require_distributed()
    p = resolve_params(params)
    r, q = _checked_images(refs, queries, advances, reference_distances)
    n_queries, n_refs = q.shape[0], r.shape[0]
    rows = _band_rows(n_refs, rows_per_band)
    in_flight = _checked_in_flight(client, in_flight)
    start_time = time.perf_counter()
    shifts = shift_list(p.shifts, r.shape[2])
    # A fresh key per call (hash=False): a content-hashed key would be the one a previous call on
    # the same references scattered, whose release may still be on its way to the scheduler and
    # would then take this call's references with it.
    refs_future = client.scatter(r, broadcast=True, hash=False)  # type: ignore[attr-defined]
    odometry = carried_odometry
    if advances is not None and reference_distances is not None:
        odometry = (advances, reference_distances)
    stream = _Stream(
        client,
        q,
        _blocks(n_queries, rows),
        (refs_future, shifts, _divisor(p, r), p.enhance_radius),
        threads_per_task,
        p.window_for(r.shape[1], r.shape[2]),
        in_flight,
        MatrixPreview(n_queries, n_refs),
        StretchSampler(n_queries) if speed_check and odometry is None else None,
        MatchesRatio(),  # takes each sampled stretch once it is whole, then drops it
    )
    confidence = off_route = speed = weights = None
    motion = None
    if p.method == "filter":
        weights = texture_weights(q, p.filter_min_texture)
        motion = motion_name(p, reference_distances is not None)
        state = _core.RouteFilter(n_refs, core_params(p, motion), reference_distances)
        matched, confidence, off_route, speed = _stream_filter(stream, state, weights, advances)
        scores = 1.0 - confidence
    else:
        matched, scores = _stream_search(stream, p)
    sampler, matches, preview = stream.sampler, stream.matches, stream.preview
    checked = None
    if speed_check:
        checked = check_speed(p, motion, None, odometry, matches if sampler is not None else None)
    # the lazy matrix in at most 8 blocks of rows: its graph is built in a fraction of a second
    _, enhanced, _ = dask_route_matrices(r, q, p, max(rows, -(-n_queries // 8)), False, threads_per_task)
    timings: dict[str, float] = {"total": time.perf_counter() - start_time}
    return RouteResult(
        refs=matched,
        scores=scores,
        enhanced=enhanced,
        difference=None,
        params=p,
        timings=timings,
        confidence=confidence,
        off_route=off_route,
        weights=weights,
        motion=motion,
        speed=speed,
        speed_check=checked,
        matrix_image=preview.image(),
    )
