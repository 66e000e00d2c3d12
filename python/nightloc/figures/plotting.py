"""Figures drawn with OpenCV: panels with axes, line/scatter/box plots and heat maps, saved as PNG.

nightloc does not depend on matplotlib; this module draws the few kinds of figure the project
needs (the paper's box plots, heat maps, difference matrices, precision-recall curves) straight
into a ``uint8`` BGR image with OpenCV. Drawing is *deferred*: calls on an :class:`Axes` record
what to draw, and :meth:`Figure.render` fixes the axis limits (from the data unless set), then
draws everything. A sketch::

    fig = Figure(width=900, height=400, cols=2, title="Distance error")
    ax = fig.axes(0, 0)
    ax.boxplot([errors_n1, errors_n10], labels=["1", "10"])
    ax.set_ylabel("error (m)")
    hm = fig.axes(0, 1)
    hm.image(heat, extent=(x0, x1, y0, y1), cmap="jet", colorbar=True)
    hm.scatter(ref_x, ref_y, size=radii, filled=False, color="green")
    fig.save("figure.png")       # atomic: temporary file + os.replace

Conventions:

* Colours are names (see :data:`NAMED_COLORS`) or ``(r, g, b)`` tuples of 0..255 ints. Images
  returned by :meth:`Figure.render` are OpenCV's BGR order, ``(height, width, 3)`` uint8.
* Data coordinates: x grows to the right, y grows *upwards* (as in a plot), whatever the pixel rows.
* :meth:`Axes.image` takes ``values[row, col]`` with row 0 at the *bottom* of ``extent`` (the
  lowest y), i.e. ``values[j, i]`` is the cell at ``x_i, y_j``, as a heat map over a map grid is
  stored. NaN cells are drawn in a neutral grey.
* Sizes (marker sizes, line thickness, fonts) are pixels.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ..io.atomic import write_bytes

__all__ = [
    "COLORMAPS",
    "NAMED_COLORS",
    "PALETTE",
    "Axes",
    "BoxStatistics",
    "Figure",
    "apply_colormap",
    "box_statistics",
    "nice_ticks",
    "save_png",
]

Color = str | tuple[int, int, int]

#: Named colours, RGB.
NAMED_COLORS: dict[str, tuple[int, int, int]] = {
    "black": (0, 0, 0),
    "white": (255, 255, 255),
    "grey": (128, 128, 128),
    "lightgrey": (215, 215, 215),
    "darkgrey": (80, 80, 80),
    "red": (214, 39, 40),
    "green": (44, 160, 44),
    "lime": (0, 230, 0),
    "blue": (31, 119, 180),
    "orange": (255, 127, 14),
    "purple": (148, 103, 189),
    "brown": (140, 86, 75),
    "pink": (227, 119, 194),
    "olive": (188, 189, 34),
    "cyan": (23, 190, 207),
    "yellow": (255, 221, 0),
    "magenta": (255, 0, 255),
}

#: Default colour cycle for series without a colour (RGB).
PALETTE: tuple[tuple[int, int, int], ...] = tuple(
    NAMED_COLORS[name]
    for name in ("blue", "orange", "green", "red", "purple", "brown", "pink", "grey", "olive", "cyan")
)

#: Colour maps by name (OpenCV's tables).
COLORMAPS: dict[str, int] = {
    "jet": cv2.COLORMAP_JET,
    "viridis": cv2.COLORMAP_VIRIDIS,
    "inferno": cv2.COLORMAP_INFERNO,
    "magma": cv2.COLORMAP_MAGMA,
    "plasma": cv2.COLORMAP_PLASMA,
    "hot": cv2.COLORMAP_HOT,
    "turbo": cv2.COLORMAP_TURBO,
    "parula": cv2.COLORMAP_PARULA,
    "bone": cv2.COLORMAP_BONE,
}

_NAN_COLOR_BGR = (200, 200, 200)
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def _bgr(color: Color) -> tuple[int, int, int]:
    """``color`` (name or RGB tuple) as an OpenCV BGR tuple."""
    if isinstance(color, str):
        try:
            r, g, b = NAMED_COLORS[color.lower()]
        except KeyError:
            raise ValueError(
                f"unknown colour {color!r}; use one of {sorted(NAMED_COLORS)} or an (r, g, b) tuple"
            ) from None
    else:
        try:
            r, g, b = (int(c) for c in color)
        except (TypeError, ValueError):
            raise ValueError(f"colour must be a name or an (r, g, b) tuple of ints, got {color!r}") from None
        if not all(0 <= c <= 255 for c in (r, g, b)):
            raise ValueError(f"colour components must lie in 0..255, got {color!r}")
    return (b, g, r)


def apply_colormap(
    values: np.ndarray, cmap: str = "jet", vmin: float | None = None, vmax: float | None = None
) -> np.ndarray:
    """Maps a float array to BGR colours: ``(...,)`` -> ``(..., 3)`` uint8.

    ``vmin``/``vmax`` default to the finite minimum/maximum; values are clipped to that range;
    NaN becomes a neutral grey.
    """
    if cmap not in COLORMAPS:
        raise ValueError(f"unknown colour map {cmap!r}; choose one of {sorted(COLORMAPS)}")
    array = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(array)
    lo, hi = _value_range(array, vmin, vmax)
    scaled = np.zeros(array.shape, dtype=np.uint8)
    if finite.any():
        scaled[finite] = np.round(255.0 * np.clip((array[finite] - lo) / (hi - lo), 0.0, 1.0)).astype(np.uint8)
    flat = scaled.reshape(-1, 1)
    colours = cv2.applyColorMap(flat, COLORMAPS[cmap]).reshape((*array.shape, 3))
    colours[~finite] = _NAN_COLOR_BGR
    return colours


def _value_range(array: np.ndarray, vmin: float | None, vmax: float | None) -> tuple[float, float]:
    finite = array[np.isfinite(array)]
    lo = float(vmin) if vmin is not None else (float(finite.min()) if finite.size else 0.0)
    hi = float(vmax) if vmax is not None else (float(finite.max()) if finite.size else 1.0)
    if not hi > lo:
        hi = lo + 1.0 if hi == lo else hi
        if not hi > lo:
            raise ValueError(f"vmax ({vmax}) must be greater than vmin ({vmin})")
    return lo, hi


def nice_ticks(lo: float, hi: float, target: int = 6) -> np.ndarray:
    """About ``target`` round tick values (steps of 1, 2 or 5 times a power of ten) within [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return np.array([lo])
    raw = (hi - lo) / max(target, 1)
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 2.5, 5, 10) if m * power >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    ticks = np.arange(first, hi + step * 1e-9, step)
    return np.round(ticks / step) * step


def _format_tick(value: float, step: float) -> str:
    if step >= 1 and abs(value) < 1e6 and abs(value - round(value)) < 1e-9:
        return str(int(round(value)))
    decimals = max(
        0, min(6, -int(math.floor(math.log10(step))) + (1 if step / 10 ** math.floor(math.log10(step)) == 2.5 else 0))
    )
    text = f"{value:.{decimals}f}"
    return "0" if text.strip("-0.") == "" else text


@dataclass(frozen=True)
class BoxStatistics:
    """Tukey box-plot numbers of one sample (the paper's Figures 10-12 style).

    Quartiles use numpy's default linear interpolation; whiskers reach the furthest data within
    1.5 IQR of the box; points beyond are outliers.
    """

    median: float
    q1: float
    q3: float
    whisker_low: float
    whisker_high: float
    outliers: np.ndarray
    count: int


def box_statistics(sample: np.ndarray, whisker: float = 1.5) -> BoxStatistics:
    """Median, quartiles, whisker ends and outliers of the finite values of ``sample``."""
    data = np.asarray(sample, dtype=np.float64).ravel()
    data = data[np.isfinite(data)]
    if data.size == 0:
        raise ValueError("a box plot needs at least one finite value per box")
    q1, median, q3 = np.percentile(data, [25, 50, 75])
    iqr = q3 - q1
    inside = data[(data >= q1 - whisker * iqr) & (data <= q3 + whisker * iqr)]
    return BoxStatistics(
        median=float(median),
        q1=float(q1),
        q3=float(q3),
        whisker_low=float(inside.min()),
        whisker_high=float(inside.max()),
        outliers=np.sort(data[(data < q1 - whisker * iqr) | (data > q3 + whisker * iqr)]),
        count=int(data.size),
    )


# ----------------------------------------------------------------------------------------------
# Artists: recorded drawing commands with their data bounds.


@dataclass
class _Artist:
    label: str | None = None

    def bounds(self) -> tuple[float, float, float, float]:
        raise NotImplementedError

    def draw(self, ax: Axes, canvas: np.ndarray) -> None:
        raise NotImplementedError


def _finite_bounds(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float, float]:
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        return (math.nan,) * 4
    return float(x[ok].min()), float(x[ok].max()), float(y[ok].min()), float(y[ok].max())


@dataclass
class _Line(_Artist):
    x: np.ndarray = field(default_factory=lambda: np.zeros(0))
    y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    color: tuple[int, int, int] = (0, 0, 0)
    thickness: int = 2
    marker: str | None = None

    def bounds(self):
        return _finite_bounds(self.x, self.y)

    def draw(self, ax, canvas):
        px, py = ax.to_local(self.x, self.y)
        ok = np.isfinite(px) & np.isfinite(py)
        # break the polyline at non-finite points
        segment: list[tuple[float, float]] = []
        runs: list[list[tuple[float, float]]] = []
        for good, a, b in zip(ok, px, py):
            if good:
                segment.append((a, b))
            elif segment:
                runs.append(segment)
                segment = []
        if segment:
            runs.append(segment)
        for run in runs:
            points = np.round(np.array(run) * 16).astype(np.int32).reshape(-1, 1, 2)
            if len(run) > 1:
                cv2.polylines(canvas, [points], False, self.color, self.thickness, cv2.LINE_AA, shift=4)
        if self.marker:
            for a, b in zip(px[ok], py[ok]):
                _marker(canvas, a, b, self.marker, 3 + self.thickness, self.color, True, 1)

    def legend_swatch(self, canvas, x, y):
        cv2.line(canvas, (x, y), (x + 20, y), self.color, self.thickness, cv2.LINE_AA)
        if self.marker:
            _marker(canvas, x + 10, y, self.marker, 3 + self.thickness, self.color, True, 1)


def _marker(canvas, x: float, y: float, kind: str, size: float, color, filled: bool, thickness: int) -> None:
    """One marker of half-size ``size`` pixels centred on (x, y) (pixel coordinates)."""
    cx, cy = int(round(x * 16)), int(round(y * 16))
    r = max(1, int(round(size * 16)))
    if kind == "o":
        cv2.circle(canvas, (cx, cy), r, color, -1 if filled else thickness, cv2.LINE_AA, shift=4)
    elif kind == "s":
        cv2.rectangle(
            canvas, (cx - r, cy - r), (cx + r, cy + r), color, -1 if filled else thickness, cv2.LINE_AA, shift=4
        )
    elif kind == "x":
        cv2.line(canvas, (cx - r, cy - r), (cx + r, cy + r), color, thickness, cv2.LINE_AA, shift=4)
        cv2.line(canvas, (cx - r, cy + r), (cx + r, cy - r), color, thickness, cv2.LINE_AA, shift=4)
    elif kind == "+":
        cv2.line(canvas, (cx - r, cy), (cx + r, cy), color, thickness, cv2.LINE_AA, shift=4)
        cv2.line(canvas, (cx, cy - r), (cx, cy + r), color, thickness, cv2.LINE_AA, shift=4)
    else:  # validated by Axes.scatter
        raise ValueError(f"unknown marker {kind!r}")


_MARKERS = ("o", "s", "x", "+")
_LEGEND_LOCATIONS = ("upper right", "upper left", "lower right", "lower left", "below")


@dataclass
class _Scatter(_Artist):
    x: np.ndarray = field(default_factory=lambda: np.zeros(0))
    y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sizes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    color: tuple[int, int, int] = (0, 0, 0)
    marker: str = "o"
    filled: bool = True
    thickness: int = 1

    def bounds(self):
        return _finite_bounds(self.x, self.y)

    def draw(self, ax, canvas):
        px, py = ax.to_local(self.x, self.y)
        for a, b, s in zip(px, py, self.sizes):
            if np.isfinite(a) and np.isfinite(b) and np.isfinite(s) and s > 0:
                _marker(canvas, a, b, self.marker, s, self.color, self.filled, self.thickness)

    def legend_swatch(self, canvas, x, y):
        finite = self.sizes[np.isfinite(self.sizes)]
        size = float(np.clip(np.median(finite) if finite.size else 5, 3, 7))
        _marker(canvas, x + 10, y, self.marker, size, self.color, self.filled, self.thickness)


@dataclass
class _Box(_Artist):
    position: float = 0.0
    stats: BoxStatistics | None = None
    width: float = 0.6
    color: tuple[int, int, int] = (0, 0, 0)
    median_color: tuple[int, int, int] = (0, 0, 255)

    def bounds(self):
        s = self.stats
        lo = min(s.whisker_low, s.outliers.min()) if s.outliers.size else s.whisker_low
        hi = max(s.whisker_high, s.outliers.max()) if s.outliers.size else s.whisker_high
        return self.position - 0.5, self.position + 0.5, lo, hi

    def draw(self, ax, canvas):
        s = self.stats
        half = self.width / 2
        (left, right), (q1, q3) = ax.to_local(
            np.array([self.position - half, self.position + half]), np.array([s.q1, s.q3])
        )
        (cx,), (lo, hi, med) = ax.to_local(
            np.array([self.position]), np.array([s.whisker_low, s.whisker_high, s.median])
        )
        (cap_l, cap_r), _ = ax.to_local(np.array([self.position - half / 2, self.position + half / 2]), np.zeros(2))
        r = lambda v: int(round(v))  # noqa: E731
        # whiskers (dashed look of the paper's Matlab plots is not needed; solid thin lines)
        cv2.line(canvas, (r(cx), r(q3)), (r(cx), r(hi)), self.color, 1, cv2.LINE_AA)
        cv2.line(canvas, (r(cx), r(q1)), (r(cx), r(lo)), self.color, 1, cv2.LINE_AA)
        cv2.line(canvas, (r(cap_l), r(hi)), (r(cap_r), r(hi)), self.color, 1, cv2.LINE_AA)
        cv2.line(canvas, (r(cap_l), r(lo)), (r(cap_r), r(lo)), self.color, 1, cv2.LINE_AA)
        cv2.rectangle(canvas, (r(left), r(q3)), (r(right), r(q1)), (255, 255, 255), -1)
        cv2.rectangle(canvas, (r(left), r(q3)), (r(right), r(q1)), self.color, 1, cv2.LINE_AA)
        cv2.line(canvas, (r(left), r(med)), (r(right), r(med)), self.median_color, 2)
        if s.outliers.size:
            _, oy = ax.to_local(np.full(s.outliers.size, self.position), s.outliers)
            for y in oy:
                _marker(canvas, cx, y, "+", 3, self.median_color, False, 1)

    def legend_swatch(self, canvas, x, y):
        cv2.rectangle(canvas, (x + 3, y - 6), (x + 17, y + 6), self.color, 1)
        cv2.line(canvas, (x + 3, y), (x + 17, y), self.median_color, 2)


@dataclass
class _Image(_Artist):
    values: np.ndarray = field(default_factory=lambda: np.zeros((1, 1)))
    extent: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 1.0)
    cmap: str = "jet"
    vmin: float = 0.0
    vmax: float = 1.0

    def bounds(self):
        return self.extent

    def draw(self, ax, canvas):
        h, w = canvas.shape[:2]
        x0, x1, y0, y1 = self.extent
        ny, nx = self.values.shape
        # data coordinates of every pixel centre of the plot area, then the cell holding it
        xs, ys = ax.to_data(np.arange(w) + 0.5, np.arange(h) + 0.5)
        col = np.floor((xs - x0) / (x1 - x0) * nx).astype(np.int64)
        row = np.floor((ys - y0) / (y1 - y0) * ny).astype(np.int64)
        cols_ok = (col >= 0) & (col < nx)
        rows_ok = (row >= 0) & (row < ny)
        if not cols_ok.any() or not rows_ok.any():
            return
        colours = apply_colormap(self.values, self.cmap, self.vmin, self.vmax)
        block = colours[np.clip(row, 0, ny - 1)[:, None], np.clip(col, 0, nx - 1)[None, :]]
        mask = rows_ok[:, None] & cols_ok[None, :]
        canvas[mask] = block[mask]


# ----------------------------------------------------------------------------------------------


@dataclass
class _Colorbar:
    cmap: str
    vmin: float
    vmax: float
    label: str


class Axes:
    """One panel of a :class:`Figure`: a plot area with axes, ticks, labels, title and legend.

    Data-space methods (:meth:`plot`, :meth:`scatter`, :meth:`boxplot`, :meth:`image`) record
    artists; limits come from :meth:`set_xlim`/:meth:`set_ylim` or from the data when the
    figure renders. After :meth:`Figure.render`, :meth:`to_pixel` maps data to figure pixels.
    """

    def __init__(self, figure: Figure, rect: tuple[int, int, int, int]):
        self._figure = figure
        self._rect = rect  # panel (x0, y0, x1, y1) in figure pixels
        self._artists: list[_Artist] = []
        self._title = ""
        self._xlabel = ""
        self._ylabel = ""
        self._xlim: tuple[float, float] | None = None
        self._ylim: tuple[float, float] | None = None
        self._xticks: tuple[np.ndarray, list[str] | None] | None = None
        self._yticks: tuple[np.ndarray, list[str] | None] | None = None
        self._equal = False
        self._grid = True
        self._legend_loc: str | None = None
        self._colorbar: _Colorbar | None = None
        self._cycle = 0
        # set by _layout
        self._box: tuple[int, int, int, int] | None = None
        self._limits: tuple[float, float, float, float] | None = None

    # -- decoration -----------------------------------------------------------------------
    def set_title(self, text: str) -> Axes:
        """Title above the panel."""
        self._title = str(text)
        return self

    def set_xlabel(self, text: str) -> Axes:
        """Label under the x axis."""
        self._xlabel = str(text)
        return self

    def set_ylabel(self, text: str) -> Axes:
        """Label left of the y axis (drawn rotated)."""
        self._ylabel = str(text)
        return self

    def set_xlim(self, lo: float, hi: float) -> Axes:
        """Fixes the x range (data units)."""
        self._xlim = _checked_limits(lo, hi, "x")
        return self

    def set_ylim(self, lo: float, hi: float) -> Axes:
        """Fixes the y range (data units)."""
        self._ylim = _checked_limits(lo, hi, "y")
        return self

    def set_xticks(self, values: Sequence[float], labels: Sequence[str] | None = None) -> Axes:
        """Tick positions (data units) on the x axis, with optional text labels."""
        self._xticks = _checked_ticks(values, labels)
        return self

    def set_yticks(self, values: Sequence[float], labels: Sequence[str] | None = None) -> Axes:
        """Tick positions (data units) on the y axis, with optional text labels."""
        self._yticks = _checked_ticks(values, labels)
        return self

    def set_aspect_equal(self, equal: bool = True) -> Axes:
        """One data unit spans as many pixels in x as in y (for maps); limits grow to fit."""
        self._equal = bool(equal)
        return self

    def set_grid(self, on: bool = True) -> Axes:
        """Light grid lines at the ticks (default on)."""
        self._grid = bool(on)
        return self

    def legend(self, loc: str = "upper right") -> Axes:
        """Draws a legend of the labelled artists at ``loc``.

        ``"upper right"``, ``"upper left"``, ``"lower right"``, ``"lower left"``: a box inside
        the plot area; ``"below"``: one row under the x-axis label (the panel makes room).
        """
        if loc not in _LEGEND_LOCATIONS:
            raise ValueError(f"legend loc must be one of {', '.join(repr(v) for v in _LEGEND_LOCATIONS)}, got {loc!r}")
        self._legend_loc = loc
        return self

    # -- artists --------------------------------------------------------------------------
    def _next_color(self, color: Color | None) -> tuple[int, int, int]:
        if color is not None:
            return _bgr(color)
        rgb = PALETTE[self._cycle % len(PALETTE)]
        self._cycle += 1
        return _bgr(rgb)

    def plot(
        self,
        x: Sequence[float],
        y: Sequence[float],
        color: Color | None = None,
        thickness: int = 2,
        label: str | None = None,
        marker: str | None = None,
    ) -> Axes:
        """A polyline through ``(x[i], y[i])``; NaN breaks the line. ``marker`` adds markers."""
        xs, ys = _xy(x, y)
        if marker is not None and marker not in _MARKERS:
            raise ValueError(f"marker must be one of {_MARKERS}, got {marker!r}")
        self._artists.append(_Line(label, xs, ys, self._next_color(color), _thickness(thickness), marker))
        return self

    def scatter(
        self,
        x: Sequence[float],
        y: Sequence[float],
        size: float | Sequence[float] = 4.0,
        color: Color | None = None,
        marker: str = "o",
        filled: bool = True,
        thickness: int = 1,
        label: str | None = None,
    ) -> Axes:
        """Markers at ``(x[i], y[i])``.

        Args:
            size: half-size (circle radius) in pixels, one value or one per point (e.g. a match
                score mapped to pixels, as in the paper's Figure 9); points with size <= 0 or NaN
                are not drawn.
            marker: ``"o"`` circle, ``"s"`` square, ``"x"`` cross, ``"+"`` plus.
            filled: filled or open circles/squares.
        """
        xs, ys = _xy(x, y)
        if marker not in _MARKERS:
            raise ValueError(f"marker must be one of {_MARKERS}, got {marker!r}")
        sizes = np.broadcast_to(np.asarray(size, dtype=np.float64), xs.shape).copy()
        self._artists.append(
            _Scatter(label, xs, ys, sizes, self._next_color(color), marker, bool(filled), _thickness(thickness))
        )
        return self

    def boxplot(
        self,
        data: Sequence[Sequence[float]],
        positions: Sequence[float] | None = None,
        labels: Sequence[str] | None = None,
        width: float = 0.6,
        color: Color | None = "black",
        median_color: Color = "red",
        label: str | None = None,
    ) -> list[BoxStatistics]:
        """Box plots, one per sample in ``data``, at x = ``positions`` (default 1, 2, ...).

        Each box spans the quartiles with a line at the median, whiskers to the furthest data
        within 1.5 IQR and ``+`` markers for outliers (:func:`box_statistics`). ``labels`` set
        the x tick labels at the positions. Returns the statistics drawn.
        """
        samples = list(data)
        if not samples:
            raise ValueError("boxplot needs at least one sample")
        pos = (
            np.arange(1, len(samples) + 1, dtype=np.float64)
            if positions is None
            else np.asarray(positions, dtype=np.float64)
        )
        if pos.shape != (len(samples),):
            raise ValueError(f"positions must have one value per sample ({len(samples)}), got shape {pos.shape}")
        if labels is not None:
            if len(labels) != len(samples):
                raise ValueError(f"labels must have one entry per sample ({len(samples)}), got {len(labels)}")
            self.set_xticks(pos, [str(t) for t in labels])
        edge = self._next_color(color)
        stats = [box_statistics(sample) for sample in samples]
        for i, (p, s) in enumerate(zip(pos, stats)):
            self._artists.append(_Box(label if i == 0 else None, float(p), s, float(width), edge, _bgr(median_color)))
        return stats

    def grouped_boxplot(
        self,
        series: Mapping[str, Sequence[Sequence[float]]],
        categories: Sequence[str],
        width: float = 0.8,
        colors: Sequence[Color] | None = None,
    ) -> dict[str, list[BoxStatistics]]:
        """Side-by-side box plots: for each category, one box per series, with a legend.

        ``series[name][i]`` is the sample of series ``name`` in category ``i``; categories sit at
        x = 1, 2, ...; each category's ``width`` is shared among the series.
        """
        names = list(series)
        if not names:
            raise ValueError("grouped_boxplot needs at least one series")
        k = len(names)
        out: dict[str, list[BoxStatistics]] = {}
        for j, name in enumerate(names):
            samples = list(series[name])
            if len(samples) != len(categories):
                raise ValueError(f"series {name!r} has {len(samples)} samples for {len(categories)} categories")
            offset = (j - (k - 1) / 2) * width / k
            positions = np.arange(1, len(categories) + 1) + offset
            color = colors[j] if colors is not None else PALETTE[j % len(PALETTE)]
            out[name] = self.boxplot(samples, positions, None, 0.8 * width / k, color, label=name)
        self.set_xticks(np.arange(1, len(categories) + 1), [str(c) for c in categories])
        if k > 1 and self._legend_loc is None:
            self.legend()
        return out

    def image(
        self,
        values: np.ndarray,
        extent: tuple[float, float, float, float],
        cmap: str = "jet",
        vmin: float | None = None,
        vmax: float | None = None,
        colorbar: bool = True,
        colorbar_label: str = "",
    ) -> Axes:
        """A heat map: ``values[j, i]`` fills the cell at column i, row j of ``extent``.

        Args:
            values: ``(ny, nx)`` float; row 0 is at the *bottom* (lowest y). NaN is grey.
            extent: ``(x_min, x_max, y_min, y_max)``: the outer edges of the cells, data units.
            cmap: a name in :data:`COLORMAPS`.
            vmin, vmax: colour range (default: finite min/max).
            colorbar: draw a colour bar right of the panel.
        """
        array = np.asarray(values, dtype=np.float64)
        if array.ndim != 2 or 0 in array.shape:
            raise ValueError(f"image values must be a non-empty 2-D array (ny, nx), got shape {array.shape}")
        if cmap not in COLORMAPS:
            raise ValueError(f"unknown colour map {cmap!r}; choose one of {sorted(COLORMAPS)}")
        x0, x1, y0, y1 = (float(v) for v in extent)
        if not (x1 > x0 and y1 > y0) or not all(map(math.isfinite, (x0, x1, y0, y1))):
            raise ValueError(f"extent must be finite (x_min, x_max, y_min, y_max) with max > min, got {extent!r}")
        lo, hi = _value_range(array, vmin, vmax)
        self._artists.insert(0, _Image(None, array, (x0, x1, y0, y1), cmap, lo, hi))
        if colorbar:
            self._colorbar = _Colorbar(cmap, lo, hi, str(colorbar_label))
        return self

    # -- coordinates ----------------------------------------------------------------------
    @property
    def plot_box(self) -> tuple[int, int, int, int]:
        """The plot area ``(x0, y0, x1, y1)`` in figure pixels (after render)."""
        if self._box is None:
            raise RuntimeError("the figure has not been rendered yet; call Figure.render() first")
        return self._box

    @property
    def limits(self) -> tuple[float, float, float, float]:
        """``(x_min, x_max, y_min, y_max)`` in data units (after render)."""
        if self._limits is None:
            raise RuntimeError("the figure has not been rendered yet; call Figure.render() first")
        return self._limits

    def to_local(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Data -> pixel coordinates inside the plot area (float; y pixel grows downwards)."""
        bx0, by0, bx1, by1 = self.plot_box
        x0, x1, y0, y1 = self.limits
        px = (np.asarray(x, dtype=np.float64) - x0) / (x1 - x0) * (bx1 - bx0)
        py = (y1 - np.asarray(y, dtype=np.float64)) / (y1 - y0) * (by1 - by0)
        return px, py

    def to_data(self, px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`to_local`."""
        bx0, by0, bx1, by1 = self.plot_box
        x0, x1, y0, y1 = self.limits
        x = x0 + np.asarray(px, dtype=np.float64) / (bx1 - bx0) * (x1 - x0)
        y = y1 - np.asarray(py, dtype=np.float64) / (by1 - by0) * (y1 - y0)
        return x, y

    def to_pixel(self, x: float, y: float) -> tuple[float, float]:
        """Data -> figure pixel coordinates (column, row) of a point (after render)."""
        px, py = self.to_local(np.array([x]), np.array([y]))
        return float(px[0] + self.plot_box[0]), float(py[0] + self.plot_box[1])

    # -- rendering ------------------------------------------------------------------------
    def _data_limits(self) -> tuple[float, float, float, float]:
        bounds = np.array([a.bounds() for a in self._artists], dtype=np.float64).reshape(-1, 4)
        has_image = any(isinstance(a, _Image) for a in self._artists)

        def axis(lo_col, hi_col, fixed, ticks):
            if fixed is not None:
                return fixed
            lo = np.nanmin(bounds[:, lo_col]) if bounds.size and np.isfinite(bounds[:, lo_col]).any() else math.nan
            hi = np.nanmax(bounds[:, hi_col]) if bounds.size and np.isfinite(bounds[:, hi_col]).any() else math.nan
            if ticks is not None:
                lo = np.nanmin([lo, ticks[0].min()])
                hi = np.nanmax([hi, ticks[0].max()])
            if not math.isfinite(lo) or not math.isfinite(hi):
                return 0.0, 1.0
            if hi - lo <= 0:
                return lo - 0.5, hi + 0.5
            if has_image and not any(isinstance(a, (_Box,)) for a in self._artists):
                return float(lo), float(hi)
            pad = 0.05 * (hi - lo)
            return float(lo - pad), float(hi + pad)

        x0, x1 = axis(0, 1, self._xlim, self._xticks)
        y0, y1 = axis(2, 3, self._ylim, self._yticks)
        return x0, x1, y0, y1

    def _layout(self, scale: float) -> None:
        px0, py0, px1, py1 = self._rect
        text_h = _text_size("0", scale)[1]
        left = int(10 + 6 * text_h) + (int(2 * text_h) if self._ylabel else 0)
        bottom = int(8 + 2.2 * text_h) + (int(2 * text_h) if self._xlabel else 0)
        if self._legend_loc == "below":
            bottom += int(2.4 * text_h) + 6
        top = int(8 + (2.2 * text_h if self._title else text_h))
        right = int(
            12
            + (
                24 + 6 * text_h + (2 * text_h if self._colorbar and self._colorbar.label else 0)
                if self._colorbar
                else 0
            )
        )
        box = [px0 + left, py0 + top, px1 - right, py1 - bottom]
        if box[2] - box[0] < 10 or box[3] - box[1] < 10:
            raise ValueError(f"panel of {px1 - px0}x{py1 - py0} pixels is too small for its labels; enlarge the figure")
        limits = self._data_limits()
        if self._equal:
            x0, x1, y0, y1 = limits
            w, h = box[2] - box[0], box[3] - box[1]
            units_per_px = max((x1 - x0) / w, (y1 - y0) / h)
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            limits = (
                cx - units_per_px * w / 2,
                cx + units_per_px * w / 2,
                cy - units_per_px * h / 2,
                cy + units_per_px * h / 2,
            )
        self._box = tuple(box)  # type: ignore[assignment]
        self._limits = limits

    def _render(self, canvas: np.ndarray, scale: float) -> None:
        self._layout(scale)
        bx0, by0, bx1, by1 = self.plot_box
        x0, x1, y0, y1 = self.limits
        area = np.full((by1 - by0, bx1 - bx0, 3), 255, dtype=np.uint8)
        xt, xl = self._ticks(self._xticks, x0, x1)
        yt, yl = self._ticks(self._yticks, y0, y1)
        if self._grid:  # under everything: heat maps hide it
            gx, _ = self.to_local(xt, np.zeros_like(xt))
            _, gy = self.to_local(np.zeros_like(yt), yt)
            for g in gx:
                cv2.line(area, (int(round(g)), 0), (int(round(g)), area.shape[0]), (235, 235, 235), 1)
            for g in gy:
                cv2.line(area, (0, int(round(g))), (area.shape[1], int(round(g))), (235, 235, 235), 1)
        for artist in self._artists:
            if isinstance(artist, _Image):
                artist.draw(self, area)
        for artist in self._artists:
            if not isinstance(artist, _Image):
                artist.draw(self, area)
        canvas[by0:by1, bx0:bx1] = area
        black = (0, 0, 0)
        cv2.rectangle(canvas, (bx0 - 1, by0 - 1), (bx1, by1), black, 1)
        text_h = _text_size("0", scale)[1]
        gx, _ = self.to_local(xt, np.zeros_like(xt))
        for g, text in zip(gx, xl):
            x = int(round(g)) + bx0
            cv2.line(canvas, (x, by1), (x, by1 + 4), black, 1)
            _put_text(canvas, text, x, by1 + 6, scale, black, "center", "top")
        _, gy = self.to_local(np.zeros_like(yt), yt)
        widest = 0
        for g, text in zip(gy, yl):
            y = int(round(g)) + by0
            cv2.line(canvas, (bx0 - 5, y), (bx0 - 1, y), black, 1)
            widest = max(widest, _put_text(canvas, text, bx0 - 8, y, scale, black, "right", "middle"))
        if self._xlabel:
            _put_text(
                canvas, self._xlabel, (bx0 + bx1) // 2, by1 + 10 + int(1.4 * text_h), scale, black, "center", "top"
            )
        if self._ylabel:
            _put_text(
                canvas, self._ylabel, bx0 - 14 - widest, (by0 + by1) // 2, scale, black, "center", "bottom", rotate=True
            )
        if self._title:
            _put_text(canvas, self._title, (bx0 + bx1) // 2, by0 - 6, scale * 1.1, black, "center", "bottom")
        if self._colorbar:
            self._draw_colorbar(canvas, scale)
        if self._legend_loc:
            self._draw_legend(canvas, scale)

    def _ticks(self, fixed, lo: float, hi: float) -> tuple[np.ndarray, list[str]]:
        if fixed is not None:
            values, labels = fixed
            inside = (values >= min(lo, hi) - 1e-9) & (values <= max(lo, hi) + 1e-9)
            if labels is None:
                step = float(np.min(np.diff(np.sort(values)))) if values.size > 1 else 1.0
                labels = [_format_tick(v, step) for v in values]
            return values[inside], [t for t, ok in zip(labels, inside) if ok]
        values = nice_ticks(lo, hi)
        step = float(values[1] - values[0]) if values.size > 1 else 1.0
        return values, [_format_tick(v, step) for v in values]

    def _draw_colorbar(self, canvas: np.ndarray, scale: float) -> None:
        bar = self._colorbar
        _bx0, by0, bx1, by1 = self.plot_box
        x0, x1 = bx1 + 12, bx1 + 26
        height = by1 - by0
        ramp = np.linspace(bar.vmax, bar.vmin, height)[:, None].repeat(x1 - x0, axis=1)
        canvas[by0:by1, x0:x1] = apply_colormap(ramp, bar.cmap, bar.vmin, bar.vmax)
        cv2.rectangle(canvas, (x0 - 1, by0 - 1), (x1, by1), (0, 0, 0), 1)
        ticks = nice_ticks(bar.vmin, bar.vmax, 5)
        step = float(ticks[1] - ticks[0]) if ticks.size > 1 else 1.0
        widest = 0
        for t in ticks:
            y = int(round(by0 + (bar.vmax - t) / (bar.vmax - bar.vmin) * (height - 1)))
            cv2.line(canvas, (x1, y), (x1 + 3, y), (0, 0, 0), 1)
            widest = max(
                widest, _put_text(canvas, _format_tick(t, step), x1 + 5, y, scale, (0, 0, 0), "left", "middle")
            )
        if bar.label:
            _put_text(
                canvas, bar.label, x1 + 10 + widest, (by0 + by1) // 2, scale, (0, 0, 0), "center", "top", rotate=True
            )

    def _draw_legend(self, canvas: np.ndarray, scale: float) -> None:
        entries = [a for a in self._artists if a.label]
        if not entries:
            return
        bx0, by0, bx1, by1 = self.plot_box
        text_h = _text_size("Ag", scale)[1]
        if self._legend_loc == "below":
            widths = [32 + _text_size(a.label, scale)[0] + 14 for a in entries]
            x = max(self._rect[0] + 4, (bx0 + bx1) // 2 - sum(widths) // 2)
            y = self._rect[3] - int(1.2 * text_h) - 4
            for artist, width in zip(entries, widths):
                artist.legend_swatch(canvas, x, y)
                _put_text(canvas, artist.label, x + 26, y, scale, (0, 0, 0), "left", "middle")
                x += width
            return
        row = int(text_h * 1.8) + 2
        width = 36 + max(_text_size(a.label, scale)[0] for a in entries) + 8
        height = row * len(entries) + 6
        lx = bx1 - width - 6 if "right" in self._legend_loc else bx0 + 6
        ly = by0 + 6 if "upper" in self._legend_loc else by1 - height - 6
        cv2.rectangle(canvas, (lx, ly), (lx + width, ly + height), (255, 255, 255), -1)
        cv2.rectangle(canvas, (lx, ly), (lx + width, ly + height), (120, 120, 120), 1)
        for i, artist in enumerate(entries):
            y = ly + 3 + row * i + row // 2
            artist.legend_swatch(canvas, lx + 6, y)
            _put_text(canvas, artist.label, lx + 32, y, scale, (0, 0, 0), "left", "middle")


def _checked_limits(lo: float, hi: float, axis: str) -> tuple[float, float]:
    lo, hi = float(lo), float(hi)
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise ValueError(f"{axis} limits must be finite with max > min, got ({lo}, {hi})")
    return lo, hi


def _checked_ticks(values, labels) -> tuple[np.ndarray, list[str] | None]:
    array = np.asarray(values, dtype=np.float64).ravel()
    if labels is not None and len(labels) != array.size:
        raise ValueError(f"tick labels must have one entry per tick ({array.size}), got {len(labels)}")
    return array, (None if labels is None else [str(t) for t in labels])


def _xy(x, y) -> tuple[np.ndarray, np.ndarray]:
    xs = np.asarray(x, dtype=np.float64).ravel()
    ys = np.asarray(y, dtype=np.float64).ravel()
    if xs.shape != ys.shape:
        raise ValueError(f"x and y must have the same length, got {xs.size} and {ys.size}")
    return xs, ys


def _thickness(value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"thickness must be an int >= 1, got {value!r}")
    return int(value)


def _text_size(text: str, scale: float) -> tuple[int, int]:
    (w, h), base = cv2.getTextSize(text, _FONT, 0.45 * scale, 1)
    return w, h + base


def _put_text(
    canvas: np.ndarray,
    text: str,
    x: int,
    y: int,
    scale: float,
    color: tuple[int, int, int],
    halign: str = "left",
    valign: str = "bottom",
    rotate: bool = False,
) -> int:
    """Draws ``text`` anchored at (x, y); ``rotate`` turns it 90 degrees counter-clockwise.

    Returns the text's extent along x on the canvas (its width, or its height when rotated).
    """
    if not text:
        return 0
    font_scale = 0.45 * scale
    (w, h), base = cv2.getTextSize(text, _FONT, font_scale, 1)
    mask = np.zeros((h + base + 2, w + 2), dtype=np.uint8)
    cv2.putText(mask, text, (1, h + 1), _FONT, font_scale, 255, 1, cv2.LINE_AA)
    if rotate:
        mask = np.ascontiguousarray(np.rot90(mask))
    mh, mw = mask.shape
    left = {"left": x, "center": x - mw // 2, "right": x - mw}[halign]
    top = {"top": y, "middle": y - mh // 2, "bottom": y - mh}[valign]
    # clip to the canvas
    cx0, cy0 = max(left, 0), max(top, 0)
    cx1, cy1 = min(left + mw, canvas.shape[1]), min(top + mh, canvas.shape[0])
    if cx1 <= cx0 or cy1 <= cy0:
        return mw
    alpha = mask[cy0 - top : cy1 - top, cx0 - left : cx1 - left, None].astype(np.float32) / 255.0
    region = canvas[cy0:cy1, cx0:cx1].astype(np.float32)
    canvas[cy0:cy1, cx0:cx1] = np.round(region * (1 - alpha) + np.array(color, np.float32) * alpha).astype(np.uint8)
    return mw


class Figure:
    """A white canvas split into ``rows x cols`` equal panels (:class:`Axes`), drawn with OpenCV.

    Args:
        width, height: size of the image in pixels.
        rows, cols: panel grid.
        title: optional figure title across the top.
        font_scale: multiplies the default text size (about 10 px high).
    """

    def __init__(
        self,
        width: int = 640,
        height: int = 480,
        rows: int = 1,
        cols: int = 1,
        title: str = "",
        font_scale: float = 1.0,
    ):
        for name, value, least in (("width", width, 64), ("height", height, 48), ("rows", rows, 1), ("cols", cols, 1)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
                raise ValueError(f"{name} must be an int >= {least}, got {value!r}")
        if not (math.isfinite(font_scale) and font_scale > 0):
            raise ValueError(f"font_scale must be positive, got {font_scale!r}")
        self.width, self.height, self.rows, self.cols = int(width), int(height), int(rows), int(cols)
        self.title = str(title)
        self.font_scale = float(font_scale)
        top = int(2.6 * _text_size("Ag", 1.2 * font_scale)[1]) if title else 0
        self._axes: list[list[Axes]] = []
        panel_w = self.width / self.cols
        panel_h = (self.height - top) / self.rows
        for r in range(self.rows):
            row = []
            for c in range(self.cols):
                rect = (
                    int(round(c * panel_w)),
                    int(round(top + r * panel_h)),
                    int(round((c + 1) * panel_w)),
                    int(round(top + (r + 1) * panel_h)),
                )
                row.append(Axes(self, rect))
            self._axes.append(row)

    def axes(self, row: int = 0, col: int = 0) -> Axes:
        """The panel at (row, col)."""
        if not (0 <= row < self.rows and 0 <= col < self.cols):
            raise IndexError(f"panel ({row}, {col}) outside the {self.rows}x{self.cols} grid")
        return self._axes[row][col]

    def render(self) -> np.ndarray:
        """Draws every panel; returns the ``(height, width, 3)`` uint8 BGR image."""
        canvas = np.full((self.height, self.width, 3), 255, dtype=np.uint8)
        if self.title:
            _put_text(canvas, self.title, self.width // 2, 6, 1.2 * self.font_scale, (0, 0, 0), "center", "top")
        for row in self._axes:
            for ax in row:
                ax._render(canvas, self.font_scale)
        return canvas

    def save(self, path: str | os.PathLike) -> Path:
        """Renders and writes a PNG atomically (see :func:`save_png`); returns the path."""
        return save_png(path, self.render())


def save_png(path: str | os.PathLike, image: np.ndarray) -> Path:
    """Writes ``image`` (``(H, W)`` grey or ``(H, W, 3)`` BGR uint8) as a PNG, atomically.

    The PNG is encoded in memory, written to a temporary file in the destination folder and
    moved into place with ``os.replace`` (:mod:`nightloc.io.atomic`): readers never see a
    half-written file, and a failure leaves any previous file untouched. Missing folders are
    created.
    """
    target = Path(path)
    array = np.asarray(image)
    if array.dtype != np.uint8 or not (array.ndim == 2 or (array.ndim == 3 and array.shape[2] in (3, 4))):
        raise ValueError(f"image must be (H, W) or (H, W, 3|4) uint8, got shape {array.shape}, dtype {array.dtype}")
    if 0 in array.shape:
        raise ValueError(f"image is empty (shape {array.shape})")
    ok, encoded = cv2.imencode(".png", array)
    if not ok:  # pragma: no cover - OpenCV failure
        raise OSError(f"OpenCV could not encode a PNG for {target}")
    return write_bytes(target, encoded.tobytes())
