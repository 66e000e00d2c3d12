"""Reference implementations of the heat-map sequence (test oracles, not library code).

* :func:`add_translated_opencv`: the compiled ``add_translated`` in three OpenCV passes;
* :func:`translate`: one heat map moved by sub-cell shifts (``scipy.ndimage.map_coordinates``
  semantics, via the compiled kernel);
* :func:`fuse`: the paper's sequence heat map, the sum of translated maps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from nightloc.localization.sequence import PaddedLayout, add_translated


def scratch(layout: PaddedLayout) -> np.ndarray:
    """A work buffer for :func:`add_translated_opencv` (two buffers' worth)."""
    return np.zeros(2 * layout.size, dtype=layout.dtype)


def add_translated_opencv(
    layout: PaddedLayout, out: np.ndarray, source: np.ndarray, shift_x: float, shift_y: float, scratch: np.ndarray
) -> None:
    """:func:`add_translated` in three OpenCV passes (the reference for the compiled kernel).

    ``scratch`` is a work buffer of ``2 * layout.size`` elements (:func:`scratch`); padding cells of ``out``
    receive garbage. Separable, three passes over the buffer: one interpolates along x at the sub-cell offset
    into the work copy (the zero column after each row gives the fade to zero), two add the rows
    of the y interpolation at their integer offsets (OpenCV's one-pass ``addWeighted`` and
    ``scaleAdd``). Before those, the work copy's columns that would land beyond the row (and so
    wrap into the next or previous one) are zeroed: they have no place in the grid anyway.
    """
    w, h = layout.width, layout.height
    ix, iy = math.floor(shift_x), math.floor(shift_y)
    fx, fy = shift_x - ix, shift_y - iy
    if ix >= w or ix < -w or iy >= h or iy + 1 <= -h:
        return  # everything lands beyond the grid
    size, stride = layout.size, layout.stride
    # (1, n) views: OpenCV would take short 1-D arrays for scalars
    src, dst, across = source.reshape(1, -1), out.reshape(1, -1), scratch[:size].reshape(1, -1)
    # across[k] = (1 - fx) * source[k] + fx * source[k - 1]: E at column (c - fx), c = 0..w
    cv2.addWeighted(src[:, 1:], 1.0 - fx, src[:, :-1], fx, 0.0, dst=across[:, 1:])
    across[0, 0] = src[0, 0] * (1.0 - fx)
    rows = across.reshape(h, stride)
    if ix > 0:
        rows[:, stride - ix :] = 0.0  # would land at columns >= w + 1
    elif ix < -1:
        rows[:, : -ix - 1] = 0.0  # would land at columns < -1 ... and wrap to the previous row
    for dy, wy in ((iy, 1.0 - fy), (iy + 1, fy)):
        if wy == 0.0 or dy >= h or dy <= -h:
            continue
        offset = dy * stride + ix
        n = size - abs(offset)
        if offset >= 0:
            target = dst[:, offset:]
            cv2.scaleAdd(across[:, :n], wy, target, dst=target)
        else:
            target = dst[:, :n]
            cv2.scaleAdd(across[:, -offset:], wy, target, dst=target)


def translate(heat: np.ndarray, shift: tuple[float, float], fill: float = 0.0) -> np.ndarray:
    """A heat map moved by ``shift = (sx, sy)`` grid cells (x along columns, y along rows).

    ``out[j, i] = E(j - sy, i - sx)``, where ``E`` is ``heat`` extended with ``fill`` beyond the
    grid and interpolated bilinearly (``scipy.ndimage.map_coordinates(..., order=1,
    mode="grid-constant", cval=fill)``). No wrap-around.

    Args:
        heat: ``(height, width)`` float.
        shift: cells; positive moves content towards higher column / row indices.
        fill: the value beyond the grid.
    """
    array = np.asarray(heat, dtype=np.float64)
    if array.ndim != 2 or 0 in array.shape:
        raise ValueError(f"heat must be a non-empty 2-D (height, width) map, got shape {array.shape}")
    sx, sy = (float(v) for v in shift)
    if not (math.isfinite(sx) and math.isfinite(sy) and math.isfinite(fill)):
        raise ValueError(f"shift and fill must be finite, got shift {shift}, fill {fill}")
    layout = PaddedLayout(*array.shape)
    out = layout.zeros()
    add_translated(layout, out, layout.pad(array - fill), sx, sy)
    return layout.view(out) + fill


def fuse(heats: Sequence[np.ndarray], offsets: np.ndarray, fills: Sequence[float] | None = None) -> np.ndarray:
    """Sum of heat maps, each translated by its offset (grid cells): the sequence heat map.

    Args:
        heats: ``n`` maps ``(height, width)``; usually the oldest first, the current last.
        offsets: ``(n, 2)`` cells ``(sx, sy)`` by which each map moves (the current map's row is
            ``(0, 0)``); see :func:`cumulative_offsets` and :meth:`HeatGrid.to_cells`.
        fills: each map's value beyond the grid (default 0).

    Returns:
        ``(height, width)`` float64: ``sum_k translate(heats[k], offsets[k], fills[k])``.
    """
    maps = [np.asarray(h, dtype=np.float64) for h in heats]
    if not maps:
        raise ValueError("fuse needs at least one heat map")
    shape = maps[0].shape
    if any(m.shape != shape for m in maps) or len(shape) != 2:
        raise ValueError(f"heat maps must all be the same 2-D shape, got {[m.shape for m in maps]}")
    shifts = np.asarray(offsets, dtype=np.float64)
    if shifts.shape != (len(maps), 2) or not np.isfinite(shifts).all():
        raise ValueError(f"offsets must be finite ({len(maps)}, 2) cells, got shape {shifts.shape}")
    fill_values = np.zeros(len(maps)) if fills is None else np.asarray(fills, dtype=np.float64)
    if fill_values.shape != (len(maps),) or not np.isfinite(fill_values).all():
        raise ValueError(f"fills must be {len(maps)} finite values")
    layout = PaddedLayout(*shape)
    out, buffer = layout.zeros(), layout.zeros()
    for heat, (sx, sy), fill in zip(maps, shifts, fill_values):
        layout.pad(heat - fill, buffer)
        add_translated(layout, out, buffer, float(sx), float(sy))
    return layout.view(out) + float(fill_values.sum())
