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
columns each of A's columns may move to for every direction of travel; :meth:`PanoramaWarper.
measure` then estimates one pair.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

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
    """Min-warping of prepared panoramas (module text).

    Args:
        images: ``(N, H, W)`` uint8 prepared 360-degree panoramas.
        params: :class:`WarpParams`.
    """

    def __init__(self, images: np.ndarray, params: WarpParams | None = None):
        self.params = params or WarpParams()
        stack = np.asarray(images)
        if stack.ndim != 3 or stack.dtype != np.uint8:
            raise ValueError(f"images must be (N, H, W) uint8, got {stack.dtype} {stack.shape}")
        self.images = stack
        _, height, width = stack.shape
        self.width = width
        p = self.params
        if p.scales == 1:
            self.scales = np.ones(1)
        else:
            self.scales = np.exp(np.linspace(-math.log(p.max_scale), math.log(p.max_scale), p.scales))
        top, bottom = math.radians(p.elevation_top), math.radians(p.elevation_bottom)
        elevation = top - (np.arange(height) + 0.5) * (top - bottom) / height
        # row weights per scale: B's rows whose source elevation lies inside A's image
        self._sources = []
        weights = np.zeros((len(self.scales), height))
        for level, s in enumerate(self.scales):
            source = (top - np.arctan(np.tan(elevation) / s)) / (top - bottom) * height - 0.5
            inside = (source >= 0) & (source <= height - 1)
            low = np.clip(np.floor(source).astype(np.intp), 0, height - 2)
            self._sources.append((low, np.clip(source - low, 0.0, 1.0), inside))
            weights[level] = inside
        self._row_weights = weights
        counts = weights.sum(axis=1)
        self._usable = counts >= max(1, height // 3)
        self._row_counts = np.maximum(counts, 1)
        self._stacks: dict[int, np.ndarray] = {}
        self._tables = self._direction_tables()

    def _stack(self, index: int) -> np.ndarray:
        """``(L, H, W)`` float32: frame ``index`` magnified by each scale (0 outside)."""
        cached = self._stacks.get(index)
        if cached is None:
            a = self.images[index].astype(np.float32)
            cached = np.zeros((len(self.scales), *a.shape), np.float32)
            for level, (low, frac, inside) in enumerate(self._sources):
                rows = (1.0 - frac)[:, None] * a[low] + frac[:, None] * a[low + 1]
                cached[level] = np.where(inside[:, None], rows, 0.0)
            self._stacks[index] = cached
        return cached

    def _direction_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For every direction of travel on the grid (``G = direction_steps * W`` directions):
        ``level (G, W, M + 1)`` the scale index of A's column ``c`` moved ``m`` columns away from
        the direction (-1 where not allowed), ``sign (G, W)`` which way it moves."""
        p = self.params
        w = self.width
        step = 2.0 * math.pi / w
        grid = p.direction_steps * w
        alphas = np.arange(grid) * (2.0 * math.pi / grid)
        moves = np.arange(w // 2 + 1)
        azimuth = -step * np.arange(w)
        theta = np.remainder(azimuth[None, :] - alphas[:, None] + math.pi, 2 * math.pi) - math.pi  # (G, W)
        sign = np.where(theta >= 0, 1, -1).astype(np.intp)
        off = np.abs(theta)
        moved = off[:, :, None] + moves[None, None, :] * step  # |theta'|
        limit = np.minimum(np.arctan2(np.sin(off), np.cos(off) - p.max_parallax), math.pi)
        allowed = moved <= limit[:, :, None] + 1e-9
        with np.errstate(divide="ignore", invalid="ignore"):
            magnification = np.sin(np.minimum(moved, math.pi)) / np.sin(off)[:, :, None]
        log_scales = np.log(self.scales)
        if len(self.scales) == 1:
            level = np.zeros(moved.shape, np.intp)
        else:
            spacing = log_scales[1] - log_scales[0]
            raw = np.rint((np.log(np.maximum(magnification, 1e-9)) - log_scales[0]) / spacing)
            level = np.clip(np.nan_to_num(raw, nan=0.0), 0, len(self.scales) - 1).astype(np.intp)
        near = (off < math.radians(p.axis_degrees)) | (off > math.pi - math.radians(p.axis_degrees))
        level = np.where(allowed, level, -1)
        level[near] = -1
        level[near, 0] = -2  # on the axis: the azimuth stays, any magnification
        return alphas, level, sign

    def column_costs(self, i: int, j: int) -> np.ndarray:
        """``(L + 1, W, W)``: mean absolute difference of A's (frame ``i``) column ``c``
        magnified by each scale against B's (frame ``j``) column ``c'``; the last layer is the
        best over the scales (for columns on the axis). Unusable scales are infinite."""
        stack = self._stack(i)  # (L, H, W)
        query = self.images[j].astype(np.float32)  # (H, W)
        diff = np.abs(stack[:, :, :, None] - query[None, :, None, :])  # (L, H, W, W)
        costs = np.einsum("lhab,lh->lab", diff, self._row_weights, optimize=True) / self._row_counts[:, None, None]
        costs[~self._usable] = np.inf
        return np.concatenate([costs, costs.min(axis=0, keepdims=True)])

    def measure(
        self,
        i: int,
        j: int,
        direction: float | None,
        direction_range: float,
        heading: float | None,
        window: int,
    ) -> WarpMeasurement:
        """Estimates ``(psi, alpha)`` of frames ``i`` (A) and ``j`` (B).

        Args:
            i, j: frame indices.
            direction: radians in A's frame, the centre of the directions of travel tried; None:
                all directions.
            direction_range: radians either side of ``direction``.
            heading: radians, the centre of the relative headings tried; None: every shift.
            window: columns either side of ``heading`` tried.
        """
        w = self.width
        alphas, level, sign = self._tables
        grid = len(alphas)
        if direction is None or direction_range >= math.pi:
            picked = np.arange(grid)
        else:
            centre = int(round(direction / (2 * math.pi) * grid))
            half = int(math.ceil(direction_range / (2 * math.pi) * grid))
            picked = np.arange(centre - half, centre + half + 1) % grid
        if heading is None or 2 * window + 1 >= w:
            shifts = np.arange(w)
            circular = True
        else:
            centre_shift = int(round(heading * w / (2 * math.pi)))
            shifts = np.arange(centre_shift - window, centre_shift + window + 1)
            circular = False
        costs = self.column_costs(i, j)  # (L + 1, W, W)
        flat = np.concatenate([costs.reshape(-1), [np.inf]])
        lv = level[picked]  # (A, W, M + 1)
        moves = np.arange(lv.shape[2])
        columns = np.arange(w)
        # B's column of A's column c moved m away from the direction, at shift k
        target = columns[None, :, None] - sign[picked][:, :, None] * moves[None, None, :]  # (A, W, M + 1)
        layer = np.where(lv == -2, len(self.scales), lv)
        base = np.where(lv == -1, -1, layer * w * w + columns[None, :, None] * w)  # (A, W, M + 1)
        out = np.empty((len(picked), len(shifts)))
        for index, k in enumerate(shifts):
            gathered = np.where(base >= 0, base + (target + k) % w, len(flat) - 1)
            best = flat[gathered].min(axis=2)  # (A, W)
            finite = np.isfinite(best)
            out[:, index] = np.where(finite, best, 0.0).sum(axis=1) / np.maximum(finite.sum(axis=1), 1)
        a, k = np.unravel_index(int(np.argmin(out)), out.shape)
        local = subcolumn_minimum(out[a], circular=circular)
        shift = (local if circular else shifts[0] + local) % w
        psi = 2.0 * math.pi * shift / w
        alpha = float(alphas[picked[a]])
        return WarpMeasurement(
            heading=psi - 2.0 * math.pi if psi > math.pi else psi,
            direction=alpha - 2.0 * math.pi if alpha > math.pi else alpha,
            cost=float(out[a, k]),
        )
