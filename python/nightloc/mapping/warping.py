"""Relative heading and direction of travel of two panoramas taken apart, by warping.

Between two places ``b`` metres apart, a landmark seen by the first panorama (A) at angle ``theta``
from the direction of travel appears in the second (B) at an angle ``theta'`` farther from it, on
the same side (``|theta| <= |theta'| <= pi``): at ``theta`` when it is far away, nearer the
direction behind the closer it is. Its distance changes by the sine rule, ``r_B / r_A = sin|theta|
/ sin|theta'|``, so its image in B is A's column magnified vertically by ``s = sin|theta'| /
sin|theta|`` (in ``tan(elevation)``, about the horizon). Given the direction of travel ``alpha``
and the relative heading ``psi``, each of A's columns can thus appear only along one short stretch
of B's columns, each with a known magnification; the landmark's distance is the one unknown, and
the column's best match over that stretch stands for it. The pair ``(alpha, psi)`` whose columns
match best (the sum over columns of each column's best match) is the estimate: *min-warping*
(Franz et al. 1998; Möller 2009), here searched over a window of ``psi`` around a prediction and
``alpha`` around the estimate's direction between the two places.

Unlike the rotation of the whole image, or its columns along the line between the places, it is
not pulled off by near walls: their columns move a lot, but where the geometry says they must.
On the synthetic living room (rows 1 m apart, walls 0.5-2 m away) the relative heading of pairs
from different rows errs 1.6 degrees (median) against 6.6 for the columns along the line
(docs/teach_run.md).

The vertical magnification needs the elevation of the prepared image's top and bottom edges
(:class:`WarpParams`; the synthetic camera's +50 to -30 degrees by default); the rows are taken
as equally spaced in elevation.

:class:`PanoramaWarper` precomputes each frame's magnified copies and the tables of which of B's
columns each of A's columns may move to for every direction of travel; the compiled core scores
the hypotheses of many pairs at once (``nightloc/warp.hpp``, GIL released, threaded), and
:meth:`PanoramaWarper.measure_many` picks each pair's best.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _core
from .._validate import thread_count
from .visual import subcolumn_minimum

__all__ = ["PanoramaWarper", "WarpMeasurement", "WarpParams"]


@dataclass(frozen=True)
class WarpParams:
    """How panoramas are warped against each other.

    Attributes:
        elevation_top, elevation_bottom: degrees; the elevation of the prepared image's top and
            bottom edges (rows equally spaced in elevation between them).
        scales: vertical magnifications compared, geometric from ``1 / max_scale`` to
            ``max_scale``.
        max_scale: the largest vertical magnification (a landmark that many times nearer).
        max_parallax: ``b / r_min``: how near a landmark may be, as a fraction of the distance
            between the two places (limits how far each column may move).
        axis_degrees: columns this close to the direction of travel (or behind) keep their
            azimuth, at any magnification.
        direction_steps: directions of travel tried per column (the grid of ``alpha``).
    """

    elevation_top: float = 50.0
    elevation_bottom: float = -30.0
    scales: int = 13
    max_scale: float = 3.0
    max_parallax: float = 2.0
    axis_degrees: float = 5.0
    direction_steps: int = 2

    def __post_init__(self) -> None:
        for name in ("elevation_top", "elevation_bottom", "max_scale", "max_parallax", "axis_degrees"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise TypeError(f"WarpParams.{name} must be a number, got {type(value).__name__}")
            if not math.isfinite(value):
                raise ValueError(f"WarpParams.{name} must be finite, got {value!r}")
        if not -90.0 < self.elevation_bottom < self.elevation_top < 90.0:
            raise ValueError(
                f"WarpParams needs -90 < elevation_bottom < elevation_top < 90 degrees, got "
                f"{self.elevation_bottom} and {self.elevation_top}"
            )
        for name in ("scales", "direction_steps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"WarpParams.{name} must be an int >= 1, got {value!r}")
        if self.max_scale < 1.0:
            raise ValueError(f"WarpParams.max_scale must be >= 1, got {self.max_scale}")
        if self.max_parallax <= 0:
            raise ValueError(f"WarpParams.max_parallax must be > 0, got {self.max_parallax}")
        if not 0 <= self.axis_degrees < 90:
            raise ValueError(f"WarpParams.axis_degrees must be in [0, 90), got {self.axis_degrees}")


@dataclass(frozen=True)
class WarpMeasurement:
    """One pair's estimate.

    Attributes:
        heading: ``heading_B - heading_A``, radians in (-pi, pi].
        direction: the direction of travel from A to B, radians counter-clockwise from A's
            heading, in (-pi, pi].
        cost: the best warp's mean column difference (grey levels).
    """

    heading: float
    direction: float
    cost: float


class PanoramaWarper:
    """Min-warping of prepared panoramas (module text), in the compiled core.

    Builds, once per drive, each frame's magnified copies (``stacks``, ``(N, L, H, W)`` uint8:
    linear interpolation between rows in 8-bit fixed point) and the tables of where each column
    may move for every direction of travel on the grid (``level``, ``sign``); the core then
    scores hypotheses ``(direction, shift)`` of many pairs at once (:meth:`costs`).

    Args:
        images: ``(N, H, W)`` uint8 prepared 360-degree panoramas.
        params: :class:`WarpParams`.
        threads: the core's threads (None: all cores).
    """

    def __init__(self, images: np.ndarray, params: WarpParams | None = None, threads: int | None = None):
        self.params = params or WarpParams()
        stack = np.asarray(images)
        if stack.ndim != 3 or stack.dtype != np.uint8:
            raise ValueError(f"images must be (N, H, W) uint8, got {stack.dtype} {stack.shape}")
        self.images = np.ascontiguousarray(stack)
        width = stack.shape[2]
        self.width = width
        self.threads = thread_count(threads)
        p = self.params
        if p.scales == 1:
            self.scales = np.ones(1)
        else:
            self.scales = np.exp(np.linspace(-math.log(p.max_scale), math.log(p.max_scale), p.scales))
        self.row_begin, self.row_end, self.stacks = _magnified(self.images, self.scales, p)
        self.directions, self.level, self.sign = _direction_tables(width, self.scales, p)
        self._cache: dict[tuple[int, ...], WarpMeasurement] = {}

    def costs(
        self,
        pairs: np.ndarray,
        first_direction: np.ndarray,
        n_directions: int,
        first_shift: np.ndarray,
        n_shifts: int,
    ) -> np.ndarray:
        """``(P, n_directions, n_shifts)`` float64 mean column costs (lower = better): pair ``p``
        (frames ``pairs[p, 0]`` = A, ``pairs[p, 1]`` = B) at grid direction ``first_direction[p]
        + d`` (of ``len(self.directions)``) and column shift ``first_shift[p] + s``."""
        return _core.warp_costs(
            self.images,
            self.stacks,
            self.row_begin,
            self.row_end,
            self.level,
            self.sign,
            np.ascontiguousarray(pairs, dtype=np.int32).reshape(-1, 2),
            np.ascontiguousarray(first_direction, dtype=np.int32),
            int(n_directions),
            np.ascontiguousarray(first_shift, dtype=np.int32),
            int(n_shifts),
            self.threads,
        )

    def measure_many(
        self,
        pairs: np.ndarray,
        directions: np.ndarray,
        direction_range: float,
        headings: np.ndarray,
        windows: np.ndarray | int,
    ) -> list[WarpMeasurement]:
        """Estimates ``(psi, alpha)`` of every pair ``(i, j)`` (A = ``i``, B = ``j``).

        A pair asked again with the same frames, directions and shifts (the teach run's next
        round, its estimate moved by less than a grid step) is answered from a cache.

        Args:
            pairs: ``(P, 2)`` frame indices.
            directions: ``(P,)`` radians in A's frame, the centre of the directions of travel
                tried (NaN: every direction).
            direction_range: radians either side of the centre.
            headings: ``(P,)`` radians, the centre of the relative headings tried (NaN: every
                shift).
            windows: ``(P,)`` (or one) columns either side of the heading's shift tried.
        """
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        directions = np.asarray(directions, dtype=np.float64).reshape(-1)
        headings = np.asarray(headings, dtype=np.float64).reshape(-1)
        windows = np.broadcast_to(np.asarray(windows, dtype=np.int64), (len(pairs),))
        w, grid = self.width, len(self.directions)
        half = int(math.ceil(direction_range / (2 * math.pi) * grid))
        every_direction = ~np.isfinite(directions) | (2 * half + 1 >= grid)
        every_shift = ~np.isfinite(headings) | (2 * windows + 1 >= w)
        first_d = np.where(
            every_direction, 0, np.rint(np.nan_to_num(directions) / (2 * math.pi) * grid).astype(np.int64) - half
        )
        n_d = np.where(every_direction, grid, 2 * half + 1)
        first_s = np.where(
            every_shift, 0, np.rint(np.nan_to_num(headings) * w / (2 * math.pi)).astype(np.int64) - windows
        )
        n_s = np.where(every_shift, w, 2 * windows + 1)
        keys = [
            (int(pairs[k, 0]), int(pairs[k, 1]), int(first_d[k] % grid), int(n_d[k]), int(first_s[k] % w), int(n_s[k]))
            for k in range(len(pairs))
        ]
        missing = [k for k, key in enumerate(keys) if key not in self._cache]
        groups: dict[tuple[int, int], list[int]] = {}
        for k in missing:
            groups.setdefault((int(n_d[k]), int(n_s[k])), []).append(k)
        for (directions_tried, shifts_tried), chosen in groups.items():
            table = self.costs(
                pairs[chosen], np.mod(first_d[chosen], grid), directions_tried, np.mod(first_s[chosen], w), shifts_tried
            )
            for row, k in enumerate(chosen):
                self._cache[keys[k]] = self._best(table[row], int(first_d[k]), int(first_s[k]), bool(every_shift[k]))
        return [self._cache[key] for key in keys]

    def measure(
        self,
        i: int,
        j: int,
        direction: float | None,
        direction_range: float,
        heading: float | None,
        window: int,
    ) -> WarpMeasurement:
        """:meth:`measure_many` of one pair; None for ``direction`` / ``heading``: all of them."""
        return self.measure_many(
            np.array([[i, j]]),
            np.array([np.nan if direction is None else direction]),
            direction_range,
            np.array([np.nan if heading is None else heading]),
            window,
        )[0]

    def _best(self, table: np.ndarray, first_direction: int, first_shift: int, circular: bool) -> WarpMeasurement:
        """The best hypothesis of one pair's ``(directions, shifts)`` table, its shift refined."""
        w, grid = self.width, len(self.directions)
        if not np.isfinite(table).any():
            return WarpMeasurement(float("nan"), float("nan"), float("inf"))
        d, k = np.unravel_index(int(np.argmin(table)), table.shape)
        local = subcolumn_minimum(table[d], circular=circular)
        shift = (first_shift + local) % w
        psi = 2.0 * math.pi * shift / w
        alpha = float(self.directions[(first_direction + d) % grid])
        return WarpMeasurement(
            heading=psi - 2.0 * math.pi if psi > math.pi else psi,
            direction=alpha - 2.0 * math.pi if alpha > math.pi else alpha,
            cost=float(table[d, k]),
        )


def _magnified(images: np.ndarray, scales: np.ndarray, params: WarpParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(row_begin, row_end, stacks)``: per scale the rows of B whose source elevation lies in
    A's image (int32 ``(L,)``), and every frame magnified by every scale, ``(N, L, H, W)`` uint8
    (8-bit fixed-point interpolation between rows; 0 outside the rows)."""
    n, height, width = images.shape
    top, bottom = math.radians(params.elevation_top), math.radians(params.elevation_bottom)
    elevation = top - (np.arange(height) + 0.5) * (top - bottom) / height
    stacks = np.zeros((n, len(scales), height, width), np.uint8)
    row_begin = np.zeros(len(scales), np.int32)
    row_end = np.zeros(len(scales), np.int32)
    wide = images.astype(np.int32)
    for level, s in enumerate(scales):
        source = (top - np.arctan(np.tan(elevation) / s)) / (top - bottom) * height - 0.5
        inside = np.flatnonzero((source >= 0) & (source <= height - 1))  # contiguous: monotone in the row
        if len(inside) < max(1, height // 3):
            continue  # too few rows to compare: the core skips an empty range
        row_begin[level], row_end[level] = inside[0], inside[-1] + 1
        low = np.clip(np.floor(source).astype(np.intp), 0, max(height - 2, 0))
        high = np.minimum(low + 1, height - 1)
        frac = np.clip(np.rint((source - low) * 256), 0, 256).astype(np.int32)
        rows = slice(inside[0], inside[-1] + 1)
        mixed = (256 - frac[rows, None]) * wide[:, low[rows], :] + frac[rows, None] * wide[:, high[rows], :]
        stacks[:, level, rows, :] = ((mixed + 128) >> 8).astype(np.uint8)
    return row_begin, row_end, stacks


def _direction_tables(width: int, scales: np.ndarray, params: WarpParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For every direction of travel on the grid (``G = direction_steps * W``): ``directions``
    ``(G,)`` radians in A's frame; ``level (G, W, M)`` int32 the scale index of A's column ``c``
    moved ``m`` columns away from the direction (``L``: any scale, for columns on the axis; -1:
    not allowed); ``sign (G, W)`` int32, column ``c`` moved ``m`` lands on ``c + k - sign * m``."""
    step = 2.0 * math.pi / width
    grid = params.direction_steps * width
    directions = np.arange(grid) * (2.0 * math.pi / grid)
    moves = np.arange(width // 2 + 1)
    azimuth = -step * np.arange(width)
    theta = np.remainder(azimuth[None, :] - directions[:, None] + math.pi, 2 * math.pi) - math.pi  # (G, W)
    sign = np.where(theta >= 0, 1, -1).astype(np.int32)
    off = np.abs(theta)
    moved = off[:, :, None] + moves[None, None, :] * step  # |theta'|
    limit = np.minimum(np.arctan2(np.sin(off), np.cos(off) - params.max_parallax), math.pi)
    allowed = moved <= limit[:, :, None] + 1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        magnification = np.sin(np.minimum(moved, math.pi)) / np.sin(off)[:, :, None]
    if len(scales) == 1:
        level = np.zeros(moved.shape, np.int32)
    else:
        log_scales = np.log(scales)
        spacing = log_scales[1] - log_scales[0]
        raw = np.rint((np.log(np.maximum(np.nan_to_num(magnification, nan=1.0), 1e-9)) - log_scales[0]) / spacing)
        level = np.clip(raw, 0, len(scales) - 1).astype(np.int32)
    near = (off < math.radians(params.axis_degrees)) | (off > math.pi - math.radians(params.axis_degrees))
    level = np.where(allowed, level, -1).astype(np.int32)
    level[near] = -1
    level[near, 0] = len(scales)  # on the axis: the azimuth stays, at any magnification
    return directions, np.ascontiguousarray(level), np.ascontiguousarray(sign)
