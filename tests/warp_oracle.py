"""Min-warping costs in numpy, straight from cpp/include/nightloc/warp.hpp's definition: the
oracle of ``nightloc._core.warp_costs`` (bit for bit: integer sums of absolute differences, one
double product per entry, sequential sums over the columns) and its benchmark's numpy side."""

from __future__ import annotations

import numpy as np


def column_costs(stack: np.ndarray, image: np.ndarray, row_begin: np.ndarray, row_end: np.ndarray) -> np.ndarray:
    """``(L + 1, W, W)``: ``cost[l, c, c']`` of frame A's magnified ``stack`` ``(L, H, W)``
    against frame B's ``image`` ``(H, W)``; layer ``L`` the least over the scales."""
    layers, _, width = stack.shape
    out = np.full((layers + 1, width, width), np.inf)
    for level in range(layers):
        begin, end = int(row_begin[level]), int(row_end[level])
        if end == begin:
            continue
        a = stack[level, begin:end].astype(np.int64)  # (rows, W)
        b = image[begin:end].astype(np.int64)
        sums = np.abs(a[:, :, None] - b[:, None, :]).sum(axis=0)  # (c, c'), exact integers
        out[level] = sums.astype(np.float64) * (1.0 / (end - begin))
    out[layers] = out[:layers].min(axis=0)
    return out


def warp_costs(
    images: np.ndarray,
    stacks: np.ndarray,
    row_begin: np.ndarray,
    row_end: np.ndarray,
    level: np.ndarray,
    sign: np.ndarray,
    pairs: np.ndarray,
    first_direction: np.ndarray,
    n_directions: int,
    first_shift: np.ndarray,
    n_shifts: int,
) -> np.ndarray:
    """``(P, n_directions, n_shifts)``, as ``nightloc._core.warp_costs``."""
    grid, width, moves = level.shape
    out = np.empty((len(pairs), n_directions, n_shifts))
    columns = np.arange(width)
    for p, (a, b) in enumerate(np.asarray(pairs)):
        cost = column_costs(stacks[a], images[b], row_begin, row_end)
        for d in range(n_directions):
            g = (int(first_direction[p]) + d) % grid
            lv = level[g]  # (W, M)
            for s in range(n_shifts):
                k = int(first_shift[p]) + s
                target = (columns[:, None] + k - sign[g][:, None] * np.arange(moves)[None, :]) % width
                values = np.where(lv >= 0, cost[np.maximum(lv, 0), columns[:, None], target], np.inf)
                best = values.min(axis=1)
                finite = np.isfinite(best)
                # sequential sum in column order (np.add.accumulate adds one after another)
                total = np.add.accumulate(np.where(finite, best, 0.0))[-1]
                out[p, d, s] = total / finite.sum() if finite.any() else np.inf
    return out
