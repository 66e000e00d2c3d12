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

Requirements: the prepared reference images are sent to every worker once (they must fit in a
worker's memory: ``n_ref * H * W`` bytes, 7 MB for 3576 Nordland frames); one block of rows,
``rows_per_block * n_ref * 4`` bytes (twice with ``keep_difference``), must fit in a task.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .. import _core
from .._validate import same_image_size, shift_list, uint8_array
from .filter import core_params, motion_name, texture_weights
from .params import RouteParams, resolve_params
from .pipeline import RouteResult, _divisor

__all__ = ["dask_available", "dask_match_prepared", "dask_route_matrices"]


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
        raise ImportError(
            'the Dask backend needs dask: pip install "nightloc[dask]" (or pip install "dask[distributed]")'
        ) from error
    return dask, da


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
