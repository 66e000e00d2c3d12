"""2D sequence matching: earlier heat maps translated by odometry and summed (paper III-E).

For the current frame ``t`` and a sequence of ``n`` frames, the fused map is

    S(q) = H_t(q) + sum_{k=1}^{n-1} H_{t-k}(q - D_k)

where ``H`` are the frames' heat maps (:mod:`nightloc.heatmap`) and ``D_k`` the displacement
from frame ``t-k`` to frame ``t`` (map frame, from odometry): a place that was hot ``k`` frames
ago, moved by the robot's motion since, is where the robot is now. The estimate is the hottest
cell of ``S`` (eq. 4 on the sum).

Translation is **sub-cell** (bilinear interpolation between the four nearest cells) with **no
wrap-around**: what moves in from beyond the grid takes the frame's fill value (its lowest heat,
the value of unmapped cells), so every cell of ``S`` sums exactly ``n`` terms.

Speed: a map is stored as its *excess* over its fill value, ``G = H - fill`` (zero outside the
hull and beyond the grid), so that ``S = sum(fill) + sum(translated G)`` and what moves in from
beyond the grid is zero. :func:`add_translated` runs the compiled kernel
(``nightloc::add_translated``: one pass, each source row interpolated along x once, SIMD, the
GIL released) on row-major buffers whose rows end with one zero column
(:class:`PaddedLayout`); :func:`add_translated_opencv` is the same translation in three OpenCV
passes (the reference, within a float rounding). The streaming :class:`~nightloc.Localizer`
keeps its sequence in the core (``nightloc::HeatSequence``) and crosses into it once per frame.
"""

from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import cv2
import numpy as np

from . import _core

__all__ = ["PaddedLayout", "translate", "add_translated", "add_translated_opencv", "fuse", "cumulative_offsets"]


class PaddedLayout:
    """Flat buffers for ``(height, width)`` maps with one zero column after each row.

    Args:
        height, width: the map's shape (grid cells).
        dtype: element type of the buffers (float64 default).
    """

    def __init__(self, height: int, width: int, dtype: np.dtype = np.float64):
        if height < 1 or width < 1:
            raise ValueError(f"map shape must be positive, got ({height}, {width})")
        self.height = int(height)
        self.width = int(width)
        self.stride = self.width + 1
        self.size = self.height * self.stride
        self.dtype = np.dtype(dtype)

    def zeros(self) -> np.ndarray:
        """A zeroed flat buffer."""
        return np.zeros(self.size, dtype=self.dtype)

    def pad(self, heat: np.ndarray, out: Optional[np.ndarray] = None) -> np.ndarray:
        """``(height, width)`` -> flat padded buffer (padding zero)."""
        if heat.shape != (self.height, self.width):
            raise ValueError(f"map must be ({self.height}, {self.width}), got shape {heat.shape}")
        buffer = self.zeros() if out is None else out
        buffer.reshape(self.height, self.stride)[:, : self.width] = heat
        return buffer

    def scratch(self) -> np.ndarray:
        """A work buffer for :func:`add_translated_opencv` (two buffers' worth)."""
        return np.zeros(2 * self.size, dtype=self.dtype)

    def view(self, buffer: np.ndarray) -> np.ndarray:
        """The ``(height, width)`` cells of a flat padded buffer (a strided view, no copy)."""
        return buffer.reshape(self.height, self.stride)[:, : self.width]


def add_translated(
    layout: PaddedLayout, out: np.ndarray, source: np.ndarray, shift_x: float, shift_y: float,
    scratch: Optional[np.ndarray] = None,
) -> None:
    """``out += source`` translated by ``(shift_x, shift_y)`` cells, bilinear, zero from outside.

    ``out[j, i] += E(j - shift_y, i - shift_x)`` where E is ``source``'s cells extended with
    zeros beyond the grid and interpolated bilinearly. ``out`` and ``source`` are flat padded
    buffers of ``layout`` (float32 or float64); read results through :meth:`PaddedLayout.view`
    (padding cells are not written). The compiled kernel needs no ``scratch`` (accepted for
    :func:`add_translated_opencv`'s signature); its rounding: with ``ix = floor(shift_x)``,
    ``fx = shift_x - ix`` (likewise y) and the weights rounded to the buffers' type,
    ``R(r, c) = (1 - fx) * G[r, c] + fx * G[r, c - 1]`` and
    ``out[j, i] = (out[j, i] + (1 - fy) * R(j - iy, i - ix)) + fy * R(j - iy - 1, i - ix)``.
    """
    if not (math.isfinite(shift_x) and math.isfinite(shift_y)):
        raise ValueError(f"shifts must be finite, got ({shift_x}, {shift_y})")
    if not (isinstance(out, np.ndarray) and out.flags.c_contiguous):
        raise ValueError("out must be a C-contiguous numpy buffer of the layout (PaddedLayout.zeros())")
    _core.add_translated(out.reshape(-1), np.ascontiguousarray(source).reshape(-1), layout.height, layout.width,
                         layout.stride, float(shift_x), float(shift_y))


def add_translated_opencv(
    layout: PaddedLayout, out: np.ndarray, source: np.ndarray, shift_x: float, shift_y: float, scratch: np.ndarray
) -> None:
    """:func:`add_translated` in three OpenCV passes (the reference for the compiled kernel).

    ``scratch`` is a work buffer from :meth:`PaddedLayout.scratch`; padding cells of ``out``
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


def translate(heat: np.ndarray, shift: Tuple[float, float], fill: float = 0.0) -> np.ndarray:
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


def cumulative_offsets(steps: np.ndarray) -> np.ndarray:
    """Displacements from each earlier frame to the current one.

    Args:
        steps: ``(k, 2)``: ``steps[m]`` moves the robot from frame ``t-k+m`` to frame
            ``t-k+m+1`` (the last row ends at the current frame ``t``).

    Returns:
        ``(k, 2)``: row ``m`` is the displacement from frame ``t-k+m`` to frame ``t`` (the sum
        of ``steps[m:]``).
    """
    s = np.asarray(steps, dtype=np.float64).reshape(-1, 2)
    return np.cumsum(s[::-1], axis=0)[::-1]


def fuse(heats: Sequence[np.ndarray], offsets: np.ndarray, fills: Optional[Sequence[float]] = None) -> np.ndarray:
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
