"""Heat maps: match scores over irregular reference positions, interpolated onto a regular grid.

The paper's section III-D, docs/design.md step 4. For one query frame, the minimum rotated scores of
all references (eq. 3, lower = more similar) are *inverted* (best = hottest, see
:func:`invert_scores`) and linearly interpolated over the reference positions onto a regular
grid; the position estimate is the hottest grid cell (eq. 4), and the closest reference to it is
reported too.

Everything that depends only on the map is computed once, in :class:`HeatMapper`: the grid, the
Delaunay triangulation of the reference positions and each cell's barycentric weights, stored as
a ``scipy.sparse`` CSR matrix ``(n_cells, n_places)``; a frame then costs one sparse product.
The streaming localizer runs that product, the sequence sum and the peak search in the compiled
core (:meth:`HeatMapper.sequence`, ``nightloc/heatmap.hpp``) with the same float32 weights.

Conventions:

* A heat map is a float64 array ``(grid_height, grid_width)``; ``heat[j, i]`` is the value at
  ``x = grid.xs[i]``, ``y = grid.ys[j]`` (cell *centres*, metres): row 0 is the lowest y.
  :meth:`HeatGrid.extent` gives the outer cell edges for matplotlib's ``imshow(heat, extent=..., origin="lower")``.
* **Outside the reference hull** (``outside="lowest"``, the default) a cell holds the frame's
  lowest inverted score: no better than the worst-matching reference, so the estimate stays
  inside the mapped area. ``outside="nearest"`` gives such cells the value of their nearest
  reference instead (the estimate may then leave the hull by up to the grid margin).
* **Interpolation off** (``interpolation=False``, the paper's comparison): every cell takes the
  value of its nearest reference (no interpolation), and the estimate is the *position of the
  reference* nearest the hottest cell. For a single frame this is exactly the best-matching
  reference's position; for sequences, the reference whose neighbourhood is hottest after fusion.
* Several references at the same position (a robot that stood still while mapping) form one
  place whose value is the best of theirs; the reported closest reference is the best-matching
  one among them.
* Degenerate layouts (fewer than three distinct positions, or all on one line) have no 2D hull:
  values are interpolated linearly *along* the line, and the "hull" is the set of cells within
  half a cell diagonal of the segment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse
from scipy.spatial import Delaunay, QhullError, cKDTree

from .. import _core
from .._validate import MAX_GRID_CELLS, MAX_SEQUENCE_CELLS, coordinates, metres, not_masked
from .sequence import PaddedLayout

__all__ = [
    "INVERSIONS",
    "OUTSIDE_MODES",
    "HeatEstimate",
    "HeatGrid",
    "HeatMapper",
    "invert_scores",
]

Inversion = Literal["range", "zscore", "negate"]
Outside = Literal["lowest", "nearest"]

#: Ways to turn scores (lower = better) into heat (higher = better), see :func:`invert_scores`.
INVERSIONS: tuple[str, ...] = ("range", "zscore", "negate")
#: Values of cells outside the reference hull, see the module docstring.
OUTSIDE_MODES: tuple[str, ...] = ("lowest", "nearest")


def invert_scores(scores: np.ndarray, mode: str = "range") -> np.ndarray:
    """Scores (lower = more similar) to heat values (higher = better), float64.

    Args:
        scores: ``(N,)`` or ``(M, N)`` match scores, one row per query frame.
        mode: ``"range"``: ``(max - s) / (max - min)`` per frame, so the best reference is 1 and
            the worst 0 (every frame weighs the same in a sequence sum); ``"zscore"``:
            ``(mean - s) / std`` per frame; ``"negate"``: ``-s`` (raw, the frames' own contrast).
            A frame whose scores are all equal gives zeros (``"negate"``: ``-s``).
    """
    if mode not in INVERSIONS:
        raise ValueError(f"inversion must be one of {INVERSIONS}, got {mode!r}")
    s = np.asarray(scores, dtype=np.float64)
    if s.ndim not in (1, 2) or s.shape[-1] == 0:
        raise ValueError(f"scores must be (n_refs,) or (n_frames, n_refs) with n_refs >= 1, got shape {s.shape}")
    if s.ndim == 1:  # the per-frame fast path: NaN and inf show in the extremes
        hi, lo = float(s.max()), float(s.min())
        if not (math.isfinite(hi) and math.isfinite(lo)):
            raise ValueError("scores contain NaN or infinity")
        if mode == "range":
            return (hi - s) * (1.0 / (hi - lo)) if hi > lo else np.zeros_like(s)
    elif not np.isfinite(s).all():
        raise ValueError("scores contain NaN or infinity")
    if mode == "negate":
        return -s
    if mode == "range":
        hi = s.max(axis=-1, keepdims=True)
        span = hi - s.min(axis=-1, keepdims=True)
        return np.divide(hi - s, span, out=np.zeros_like(s), where=span > 0)
    centre = s.mean(axis=-1, keepdims=True)
    spread = s.std(axis=-1, keepdims=True)
    return np.divide(centre - s, spread, out=np.zeros_like(s), where=spread > 0)


@dataclass(frozen=True)
class HeatGrid:
    """A regular grid of cell centres in the map frame.

    Attributes:
        x0, y0: centre of cell ``[0, 0]`` (metres; the lowest x and y).
        dx, dy: cell spacing (metres).
        width, height: number of cells along x and y.
    """

    x0: float
    y0: float
    dx: float
    dy: float
    width: int
    height: int

    @classmethod
    def spanning(cls, positions: np.ndarray, width: int = 100, height: int = 100, margin: float = 0.25) -> HeatGrid:
        """The grid whose outermost cell centres lie ``margin`` metres beyond the positions' bounds.

        A zero extent along an axis (all positions on one vertical or horizontal line, or one
        point) is widened to ``max(2 * margin, 1)`` metres centred on the points.
        """
        pos = _positions(positions)
        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 2:
                raise ValueError(f"grid {name} must be an int >= 2 cells, got {value!r}")
        if int(width) * int(height) > MAX_GRID_CELLS:
            raise ValueError(
                f"grid of {width}x{height} cells is too large (at most {MAX_GRID_CELLS} cells, MAX_GRID_CELLS)"
            )
        metres(margin, "margin", minimum=0.0)
        lo = pos.min(axis=0) - margin
        hi = pos.max(axis=0) + margin
        for axis in range(2):
            if hi[axis] - lo[axis] <= 1e-9:
                centre, half = (lo[axis] + hi[axis]) / 2, max(2 * margin, 1.0) / 2
                lo[axis], hi[axis] = centre - half, centre + half
        return cls(
            float(lo[0]),
            float(lo[1]),
            float((hi[0] - lo[0]) / (width - 1)),
            float((hi[1] - lo[1]) / (height - 1)),
            int(width),
            int(height),
        )

    @property
    def xs(self) -> np.ndarray:
        """``(width,)`` x of the cell centres (metres)."""
        return self.x0 + self.dx * np.arange(self.width)

    @property
    def ys(self) -> np.ndarray:
        """``(height,)`` y of the cell centres (metres)."""
        return self.y0 + self.dy * np.arange(self.height)

    @property
    def shape(self) -> tuple[int, int]:
        """``(height, width)``: the shape of a heat map."""
        return (self.height, self.width)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(x_min, x_max, y_min, y_max)``: the outer cell edges, for plotting."""
        return (
            self.x0 - self.dx / 2,
            self.x0 + self.dx * (self.width - 0.5),
            self.y0 - self.dy / 2,
            self.y0 + self.dy * (self.height - 0.5),
        )

    def centres(self) -> np.ndarray:
        """``(height * width, 2)`` cell centres in row-major order (``k = j * width + i``)."""
        gx, gy = np.meshgrid(self.xs, self.ys)
        return np.column_stack([gx.ravel(), gy.ravel()])

    def position(self, flat_index: int) -> tuple[float, float]:
        """Centre ``(x, y)`` of the cell with row-major index ``flat_index``."""
        j, i = divmod(int(flat_index), self.width)
        return self.x0 + self.dx * i, self.y0 + self.dy * j

    def to_cells(self, displacement: np.ndarray) -> np.ndarray:
        """Metres ``(..., 2)`` to cells ``(..., 2)`` (x over dx, y over dy)."""
        d = np.asarray(displacement, dtype=np.float64)
        return d / np.array([self.dx, self.dy])


@dataclass(frozen=True)
class HeatEstimate:
    """Where a heat map is hottest.

    Attributes:
        x, y: the estimate (metres): the hottest cell's centre, or with interpolation off the
            position of the reference nearest to it.
        ref_index: the reference closest to the hottest cell (index into the map).
        cell: row-major index of the hottest cell.
        peak: the heat map's maximum.
        confidence: ``(peak - second) / (peak - floor)`` in [0, 1], where ``second`` is the
            highest value farther than the confidence radius from the peak and ``floor`` the
            map's minimum: 1 = one clear place, 0 = another place is as hot.
    """

    x: float
    y: float
    ref_index: int
    cell: int
    peak: float
    confidence: float


def _positions(positions: object) -> np.ndarray:
    not_masked(positions, "positions")
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 2 or pos.shape[0] == 0:
        raise ValueError(f"positions must be (n_refs, 2) metres with n_refs >= 1, got shape {pos.shape}")
    coordinates(pos, "positions")
    return pos


class HeatMapper:
    """Turns one frame's match scores into a heat map over a fixed grid (computed once per map).

    Args:
        positions: ``(N, 2)`` reference positions, metres (``ReferenceMap.positions``).
        grid_width, grid_height: cells along x and y (the paper's 100 x 100).
        margin: metres between the outermost references and the outermost cell centres.
        interpolation: linear interpolation (True) or nearest reference (False, the paper's
            comparison); see the module docstring.
        outside: ``"lowest"`` or ``"nearest"``: the value of cells outside the reference hull.
        inversion: how scores become heat (:func:`invert_scores`).
        confidence_radius: metres around the peak excluded when looking for the second peak.

    Attributes:
        grid: the :class:`HeatGrid`.
        weights: ``scipy.sparse.csr_matrix`` ``(n_cells, n_places)``: heat = weights @ place values.
        inside: ``(height, width)`` bool, cells inside the reference hull.
    """

    def __init__(
        self,
        positions: np.ndarray,
        grid_width: int = 100,
        grid_height: int = 100,
        margin: float = 0.25,
        interpolation: bool = True,
        outside: str = "lowest",
        inversion: str = "range",
        confidence_radius: float = 1.0,
    ):
        pos = _positions(positions)
        if outside not in OUTSIDE_MODES:
            raise ValueError(f"outside must be one of {OUTSIDE_MODES}, got {outside!r}")
        if inversion not in INVERSIONS:
            raise ValueError(f"inversion must be one of {INVERSIONS}, got {inversion!r}")
        metres(confidence_radius, "confidence_radius", minimum=0.0)
        self.positions = pos
        self.grid = HeatGrid.spanning(pos, grid_width, grid_height, margin)
        self.interpolation = bool(interpolation)
        self.outside = outside
        self.inversion = inversion
        self.confidence_radius = float(confidence_radius)
        self._group_places(pos)
        # Triangulation, weights and nearest places in coordinates local to the map: map frames
        # far from 0 (UTM: 5e6 m) would otherwise lose Delaunay's precision to metres of error.
        origin = self._places.mean(axis=0)
        local_places = self._places - origin
        cells = self.grid.centres() - origin
        self._nearest_place = cKDTree(local_places).query(cells)[1].astype(np.intp)
        if self.interpolation:
            weights, inside = _interpolation_weights(local_places, cells, self.grid)
            if outside == "nearest":
                outside_cells = np.flatnonzero(~inside)
                extra = scipy.sparse.csr_matrix(
                    (np.ones(outside_cells.size), (outside_cells, self._nearest_place[outside_cells])),
                    shape=weights.shape,
                )
                weights = (weights + extra).tocsr()
        else:
            n = cells.shape[0]
            weights = scipy.sparse.csr_matrix(
                (np.ones(n), (np.arange(n), self._nearest_place)), shape=(n, len(self._places))
            )
            inside = np.ones(n, dtype=bool)
        weights.sort_indices()
        self.weights = weights
        # the same weights with rows at their places in a padded sequence buffer (see sequence.py)
        # float32 (half the memory traffic of the sequence sums; ~1e-7 relative rounding)
        self.layout = PaddedLayout(*self.grid.shape, dtype=np.float32)
        coo = weights.tocoo()
        row, col = np.divmod(coo.row, self.grid.width)
        self._padded_weights = scipy.sparse.csr_matrix(
            (coo.data.astype(np.float32), (row * self.layout.stride + col, coo.col)),
            shape=(self.layout.size, weights.shape[1]),
        )
        self._padded_weights.sort_indices()
        self._fill_mask = ~inside if (self.interpolation and outside == "lowest") else None
        self.inside = inside.reshape(self.grid.shape)
        self.inside.setflags(write=False)
        self._disk = _disk_offsets(self.grid, self.confidence_radius)
        # the float32 weights of the compiled sequences (shared by all of them, read-only)
        self._core_weights = _core.HeatWeights(
            self.grid.height,
            self.grid.width,
            weights.shape[1],
            weights.indptr.astype(np.int32),
            weights.indices.astype(np.int32),
            weights.data.astype(np.float32),
        )

    def _group_places(self, pos: np.ndarray) -> None:
        """Distinct positions ("places") and, per place, the references standing there."""
        places, inverse = np.unique(np.round(pos, 9), axis=0, return_inverse=True)
        inverse = np.asarray(inverse).ravel()
        order = np.argsort(inverse, kind="stable")
        self._places = places
        self.place_of_ref = inverse.astype(np.int32)  # (N,) the place each reference stands at
        self._order = order  # references sorted by place
        self._starts = np.flatnonzero(np.r_[True, np.diff(inverse[order]) != 0])
        self._all_distinct = len(places) == len(pos)
        self._members = np.split(order, self._starts[1:])

    @property
    def n_refs(self) -> int:
        """Number of references."""
        return self.positions.shape[0]

    def place_values(self, values: np.ndarray) -> np.ndarray:
        """Per-reference values ``(N,)`` to per-place values (best of references sharing a place)."""
        if self._all_distinct:
            return values[self._order]
        return np.maximum.reduceat(values[self._order], self._starts)

    def interpolate(self, values: np.ndarray, fill: float = math.nan) -> np.ndarray:
        """Any per-reference field ``(N,)`` onto the grid ``(height, width)``.

        Inside the hull the field is linear on each Delaunay triangle (exact for a planar field);
        cells outside get ``fill`` (``outside="lowest"``) or their nearest reference's value.
        """
        v = np.asarray(values, dtype=np.float64)
        if v.shape != (self.n_refs,):
            raise ValueError(f"values must be ({self.n_refs},), one per reference, got shape {v.shape}")
        heat = self.weights @ self.place_values(v)
        if self._fill_mask is not None:
            heat[self._fill_mask] = fill
        return heat.reshape(self.grid.shape)

    def heat_map(self, scores: np.ndarray) -> tuple[np.ndarray, float]:
        """One frame's heat map and the value used for cells without data.

        Args:
            scores: ``(N,)`` minimum rotated scores of the frame against each reference (eq. 3).

        Returns:
            ``(heat, fill)``: heat ``(height, width)`` float64; ``fill`` is the frame's lowest
            inverted score, the value of cells outside the hull (``outside="lowest"``) and of
            cells translated in from beyond the grid in a sequence.
        """
        s = np.asarray(scores)
        if s.shape != (self.n_refs,):
            raise ValueError(f"scores must be ({self.n_refs},), one per reference, got shape {s.shape}")
        inverted = invert_scores(s, self.inversion)
        fill = float(inverted.min())
        return self.interpolate(inverted, fill), fill

    def place_excess(self, scores: np.ndarray) -> tuple[np.ndarray, float]:
        """One frame's inverted scores minus its fill value, per place, and the fill value.

        Returns ``(values, fill)``: ``values`` float32 ``(n_places,)``, the input of the sparse
        product (:meth:`excess`, :meth:`sequence`); ``fill`` as in :meth:`heat_map`. Raises
        ValueError for a wrong shape, NaN or infinity.
        """
        s = np.asarray(scores)
        if s.shape != (self.n_refs,):
            raise ValueError(f"scores must be ({self.n_refs},), one per reference, got shape {s.shape}")
        inverted = invert_scores(s, self.inversion)
        fill = float(inverted.min())
        inverted -= fill
        return self.place_values(inverted).astype(np.float32), fill

    def excess(self, scores: np.ndarray) -> tuple[np.ndarray, float]:
        """One frame's heat map minus its fill value, in a flat padded float32 buffer.

        Returns ``(buffer, fill)``: ``self.layout.view(buffer) + fill`` equals
        :meth:`heat_map`; the buffer is zero outside the hull and in the padding. Interpolation
        weights sum to one, so this is one sparse product of the inverted scores minus ``fill``.
        """
        values, fill = self.place_excess(scores)
        return self._padded_weights @ values, fill

    def sequence(self, capacity: int) -> _core.HeatSequence:
        """A compiled sequence of up to ``capacity`` frames over this grid (the localizer's engine).

        ``push(values, fill)`` adds a frame from :meth:`place_excess` (its excess map is the
        sparse product with :attr:`weights` in float32, summed in scipy's order);
        ``fuse_peak(offsets)`` sums the newest excess map and the earlier ones translated by
        ``offsets`` (``(size - 1, 2)`` cells, oldest first, see
        :func:`nightloc.localization.sequence.add_translated` for the rounding) and returns
        ``(fill_sum, cell, peak, floor, second)`` for :meth:`estimate_from_peak`; ``fused()``,
        ``frame(k)`` and ``fill(k)`` give the maps (float32 copies); ``clear()``; ``size``.
        The weights are shared by every sequence of this mapper.
        """
        if isinstance(capacity, bool) or not isinstance(capacity, (int, np.integer)) or capacity < 1:
            raise ValueError(f"capacity must be an int >= 1 frames, got {capacity!r}")
        if int(capacity) * self.layout.size > MAX_SEQUENCE_CELLS:
            raise ValueError(
                f"a sequence of {capacity} frames over a {self.grid.width}x{self.grid.height} grid holds "
                f"{int(capacity) * self.layout.size} float32 cells, more than {MAX_SEQUENCE_CELLS} "
                f"(MAX_SEQUENCE_CELLS, 512 MiB); shorten the sequence or coarsen the grid"
            )
        rj, ri, disk = self._disk
        return _core.HeatSequence(self._core_weights, int(capacity), rj, ri, disk.astype(np.uint8).ravel())

    def closest_ref(self, cell: int, scores: np.ndarray | None = None) -> int:
        """The reference nearest to cell ``cell`` (the best-scoring one where several share a place)."""
        members = self._members[self._nearest_place[cell]]
        if len(members) == 1 or scores is None:
            return int(members[0])
        return int(members[np.argmin(np.asarray(scores)[members])])

    def estimate(self, heat: np.ndarray, scores: np.ndarray | None = None) -> HeatEstimate:
        """The hottest cell of ``heat`` (eq. 4; the first in row-major order on ties). A flat
        map (a single place, or every score equal) gives the best-scoring reference's position.

        Args:
            heat: ``(height, width)`` heat map (one frame's or a sequence sum).
            scores: the current frame's scores, to choose among references sharing a place.
        """
        h = np.asarray(heat)
        if h.shape != self.grid.shape:
            raise ValueError(f"heat must be {self.grid.shape} (height, width), got shape {h.shape}")
        flat = h.reshape(-1)
        cell = int(np.argmax(flat))
        peak = float(flat[cell])
        if not math.isfinite(peak):
            raise ValueError("heat map contains NaN or infinity")
        floor = float(flat.min())
        if peak <= floor:
            return self._flat_estimate(peak, scores)
        return self._peak_estimate(cell, peak, scores, self._confidence(h, cell, peak))

    def estimate_from_peak(
        self, cell: int, peak: float, floor: float, second: float | None, scores: np.ndarray | None = None
    ) -> HeatEstimate:
        """:meth:`estimate` from a peak found elsewhere (``HeatSequence.fuse_peak``): the hottest
        cell, the map's maximum and minimum, and the highest value farther than the confidence
        radius from the peak (None when no cell is that far)."""
        if peak <= floor:
            return self._flat_estimate(peak, scores)
        confidence = 1.0 if second is None else min(max((peak - second) / (peak - floor), 0.0), 1.0)
        return self._peak_estimate(int(cell), float(peak), scores, confidence)

    def _flat_estimate(self, peak: float, scores: np.ndarray | None) -> HeatEstimate:
        # A flat map (one place, or every score equal) has no peak: the answer is the best
        # reference (the lowest index on ties, as in matching), not the grid's first cell.
        ref = int(np.argmin(scores)) if scores is not None else 0
        x, y = (float(v) for v in self.positions[ref])
        return HeatEstimate(x, y, ref, self._cell_of(x, y), peak, 0.0)

    def _peak_estimate(self, cell: int, peak: float, scores: np.ndarray | None, confidence: float) -> HeatEstimate:
        ref = self.closest_ref(cell, scores)
        if self.interpolation:
            x, y = self.grid.position(cell)
        else:
            x, y = (float(v) for v in self.positions[ref])
        return HeatEstimate(float(x), float(y), ref, cell, peak, confidence)

    def _cell_of(self, x: float, y: float) -> int:
        """The flat index of the grid cell nearest to ``(x, y)``."""
        g = self.grid
        i = min(max(int(round((x - g.x0) / g.dx)), 0), g.width - 1)
        j = min(max(int(round((y - g.y0) / g.dy)), 0), g.height - 1)
        return j * g.width + i

    def _confidence(self, heat: np.ndarray, cell: int, peak: float) -> float:
        floor = float(heat.min())
        if peak <= floor:
            return 0.0
        height, width = self.grid.shape
        j, i = divmod(cell, width)
        rj, ri, disk = self._disk
        j0, j1 = max(j - rj, 0), min(j + rj + 1, height)
        i0, i1 = max(i - ri, 0), min(i + ri + 1, width)
        # the highest value beyond the radius: the map outside the disk's bounding box, and the
        # box's cells outside the disk (no copy of the map)
        parts = []
        if j0 > 0:
            parts.append(heat[:j0].max())
        if j1 < height:
            parts.append(heat[j1:].max())
        if i0 > 0:
            parts.append(heat[j0:j1, :i0].max())
        if i1 < width:
            parts.append(heat[j0:j1, i1:].max())
        ring = heat[j0:j1, i0:i1][~disk[j0 - j + rj : j1 - j + rj, i0 - i + ri : i1 - i + ri]]
        if ring.size:
            parts.append(ring.max())
        if not parts:
            return 1.0
        second = float(max(parts))
        return float(np.clip((peak - second) / (peak - floor), 0.0, 1.0))


def _disk_offsets(grid: HeatGrid, radius: float) -> tuple[int, int, np.ndarray]:
    """Half-sizes (rows, cols) of the box around ``radius`` metres and the disk mask inside it.

    The box is clipped to the grid's own size: an offset of ``height`` rows or ``width`` columns
    leaves the grid from any cell, so a radius wider than the map gives the same answers with a
    mask of at most ``(2 height - 1) x (2 width - 1)`` cells (not gigabytes).
    """
    rj = int(min(math.floor(radius / grid.dy), grid.height - 1))
    ri = int(min(math.floor(radius / grid.dx), grid.width - 1))
    dj, di = np.mgrid[-rj : rj + 1, -ri : ri + 1]
    return rj, ri, (dj * grid.dy) ** 2 + (di * grid.dx) ** 2 <= radius**2 + 1e-12


def _interpolation_weights(
    places: np.ndarray, cells: np.ndarray, grid: HeatGrid
) -> tuple[scipy.sparse.csr_matrix, np.ndarray]:
    """Sparse linear-interpolation weights ``(n_cells, n_places)`` and the inside-hull mask."""
    n_cells, n_places = cells.shape[0], places.shape[0]
    triangulation = None
    if n_places >= 3 and _hull_width(places) > 0.5 * math.hypot(grid.dx, grid.dy):
        try:
            triangulation = Delaunay(places)
        except QhullError:  # all on one line
            triangulation = None
    if triangulation is None:  # a point, a line, or a sliver thinner than a cell: along the line
        return _line_weights(places, cells, grid)
    simplex, bary = _locate_cells(places, triangulation.simplices, cells, grid)
    inside = simplex >= 0
    rows = np.flatnonzero(inside)
    vertices = triangulation.simplices[simplex[inside]]
    weights = scipy.sparse.csr_matrix(
        (bary[inside].ravel(), (np.repeat(rows, 3), vertices.ravel())), shape=(n_cells, n_places)
    )
    weights.eliminate_zeros()
    return weights, inside


def _locate_cells(
    places: np.ndarray, simplices: np.ndarray, cells: np.ndarray, grid: HeatGrid, tol: float = 100 * np.finfo(float).eps
) -> tuple[np.ndarray, np.ndarray]:
    """The triangle holding each cell centre and its barycentric coordinates, ``(n_cells,)`` (-1 for
    none) and ``(n_cells, 3)``: each triangle tests the grid cells of its bounding box (the cells
    are a regular grid); a cell on an edge shared by two triangles takes the one it lies deepest in.

    (What ``Delaunay.find_simplex`` and ``.transform`` give, in numpy: those compute the per-triangle
    transforms with one LAPACK call each, which a threaded BLAS makes slow on a busy machine.)"""
    n_cells = cells.shape[0]
    v = places[simplices]  # (T, 3, 2)
    # the affine map to barycentric coordinates: b01 = inv([v0 - v2, v1 - v2]) (p - v2)
    e = np.stack([v[:, 0] - v[:, 2], v[:, 1] - v[:, 2]], axis=2)  # (T, 2, 2): columns v0 - v2, v1 - v2
    det = e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0]
    usable = np.abs(det) > 0
    inv = np.zeros_like(e)
    d = np.where(usable, det, 1.0)
    inv[:, 0, 0], inv[:, 0, 1] = e[:, 1, 1] / d, -e[:, 0, 1] / d
    inv[:, 1, 0], inv[:, 1, 1] = -e[:, 1, 0] / d, e[:, 0, 0] / d
    # each triangle's bounding box in cell indices (cell (j, i) centre: cells[j * width + i])
    x0, y0 = cells[0]
    lo = np.floor((v.min(axis=1) - (x0, y0)) / (grid.dx, grid.dy) - 1e-9).astype(np.int64)
    hi = np.ceil((v.max(axis=1) - (x0, y0)) / (grid.dx, grid.dy) + 1e-9).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, (grid.width - 1, grid.height - 1))
    ni, nj = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0), np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    count = np.where(usable, ni * nj, 0)
    tri = np.repeat(np.arange(len(simplices)), count)
    offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)  # within the box
    i = lo[tri, 0] + offset % ni[tri]
    j = lo[tri, 1] + offset // ni[tri]
    cell = j * grid.width + i
    rel = cells[cell] - v[tri, 2]
    b0 = inv[tri, 0, 0] * rel[:, 0] + inv[tri, 0, 1] * rel[:, 1]
    b1 = inv[tri, 1, 0] * rel[:, 0] + inv[tri, 1, 1] * rel[:, 1]
    bary = np.column_stack([b0, b1, 1.0 - b0 - b1])
    depth = bary.min(axis=1)
    keep = depth >= -tol
    cell, tri, bary, depth = cell[keep], tri[keep], bary[keep], depth[keep]
    order = np.lexsort((-depth, cell))  # per cell the deepest triangle first
    first = np.r_[True, np.diff(cell[order]) != 0]
    chosen = order[first]
    simplex = np.full(n_cells, -1, dtype=np.int64)
    out = np.zeros((n_cells, 3))
    simplex[cell[chosen]] = tri[chosen]
    out[cell[chosen]] = bary[chosen]
    return simplex, out


def _hull_width(places: np.ndarray) -> float:
    """Extent of the places across their principal direction (0 for collinear places)."""
    centred = places - places.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    across = centred @ vt[-1]
    return float(across.max() - across.min())


def _line_weights(places: np.ndarray, cells: np.ndarray, grid: HeatGrid) -> tuple[scipy.sparse.csr_matrix, np.ndarray]:
    """Degenerate layouts: linear interpolation along the line through the places."""
    n_cells, n_places = cells.shape[0], places.shape[0]
    centre = places.mean(axis=0)
    if n_places == 1:
        direction = np.array([1.0, 0.0])
    else:
        _, _, vt = np.linalg.svd(places - centre)
        direction = vt[0]
    t_places = (places - centre) @ direction
    order = np.argsort(t_places)
    t_sorted = t_places[order]
    t_cells = (cells - centre) @ direction
    foot = np.clip(t_cells, t_sorted[0], t_sorted[-1])
    distance = np.hypot(*(cells - (centre + np.outer(foot, direction))).T)
    inside = distance <= 0.5 * math.hypot(grid.dx, grid.dy) + 1e-12
    rows = np.flatnonzero(inside)
    if n_places == 1:
        weights = scipy.sparse.csr_matrix((np.ones(rows.size), (rows, np.zeros(rows.size, int))), shape=(n_cells, 1))
        return weights, inside
    upper = np.clip(np.searchsorted(t_sorted, foot[rows], side="right"), 1, n_places - 1)
    lower = upper - 1
    span = t_sorted[upper] - t_sorted[lower]  # 0 where two places project to one point of the line
    frac = np.clip(np.divide(foot[rows] - t_sorted[lower], span, out=np.zeros(rows.size), where=span > 0), 0.0, 1.0)
    data = np.concatenate([1.0 - frac, frac])
    cols = np.concatenate([order[lower], order[upper]])
    weights = scipy.sparse.csr_matrix((data, (np.concatenate([rows, rows]), cols)), shape=(n_cells, n_places))
    weights.eliminate_zeros()
    return weights, inside
