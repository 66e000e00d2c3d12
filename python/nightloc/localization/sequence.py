"""2D sequence matching: earlier heat maps translated by odometry and summed (paper III-E).

For the current frame ``t`` and a sequence of ``n`` frames, the fused map is

    S(q) = H_t(q) + sum_{k=1}^{n-1} H_{t-k}(q - D_k)

where ``H`` are the frames' heat maps (:mod:`nightloc.localization.heatmap`) and ``D_k`` the displacement
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
(:class:`PaddedLayout`); the tests check it against the same translation in three OpenCV passes
and against ``scipy.ndimage.map_coordinates``. The streaming :class:`~nightloc.Localizer`
keeps its sequence in the core (``nightloc::HeatSequence``) and crosses into it once per frame.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from .. import _core

__all__ = ["PaddedLayout", "add_translated", "cumulative_offsets"]


class PaddedLayout:
    """Flat buffers for ``(height, width)`` maps with one zero column after each row.

    Args:
        height, width: the map's shape (grid cells).
        dtype: element type of the buffers (float64 default).
    """

    def __init__(self, height: int, width: int, dtype: npt.DTypeLike = np.float64):
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

    def pad(self, heat: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """``(height, width)`` -> flat padded buffer (padding zero)."""
        if heat.shape != (self.height, self.width):
            raise ValueError(f"map must be ({self.height}, {self.width}), got shape {heat.shape}")
        buffer = self.zeros() if out is None else out
        buffer.reshape(self.height, self.stride)[:, : self.width] = heat
        return buffer

    def view(self, buffer: np.ndarray) -> np.ndarray:
        """The ``(height, width)`` cells of a flat padded buffer (a strided view, no copy)."""
        return buffer.reshape(self.height, self.stride)[:, : self.width]


def add_translated(layout: PaddedLayout, out: np.ndarray, source: np.ndarray, shift_x: float, shift_y: float) -> None:
    """``out += source`` translated by ``(shift_x, shift_y)`` cells, bilinear, zero from outside.

    ``out[j, i] += E(j - shift_y, i - shift_x)`` where E is ``source``'s cells extended with
    zeros beyond the grid and interpolated bilinearly. ``out`` and ``source`` are flat padded
    buffers of ``layout`` (float32 or float64); read results through :meth:`PaddedLayout.view`
    (padding cells are not written). The kernel's rounding: with ``ix = floor(shift_x)``,
    ``fx = shift_x - ix`` (likewise y) and the weights rounded to the buffers' type,
    ``R(r, c) = (1 - fx) * G[r, c] + fx * G[r, c - 1]`` and
    ``out[j, i] = (out[j, i] + (1 - fy) * R(j - iy, i - ix)) + fy * R(j - iy - 1, i - ix)``.
    """
    if not (math.isfinite(shift_x) and math.isfinite(shift_y)):
        raise ValueError(f"shifts must be finite, got ({shift_x}, {shift_y})")
    if not (isinstance(out, np.ndarray) and out.flags.c_contiguous):
        raise ValueError("out must be a C-contiguous numpy buffer of the layout (PaddedLayout.zeros())")
    if isinstance(source, np.ndarray) and np.shares_memory(out, source):
        raise ValueError(
            "out and source share memory: the translation would read cells it has already written; "
            "pass a copy of source"
        )
    _core.add_translated(
        out.reshape(-1),
        np.ascontiguousarray(source).reshape(-1),
        layout.height,
        layout.width,
        layout.stride,
        float(shift_x),
        float(shift_y),
    )


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
