"""Scene geometry of the synthetic worlds: vertical prisms and their intersections with rays.

Every solid in a world is a *vertical prism*: a convex footprint in the ground plane (a polygon or
a circle), extruded from ``bottom`` to ``top`` metres. Walls, fences, furniture, tree trunks and
canopies, the ceiling: all are prisms, so one intersection routine gives exact occlusion and
parallax. The ground is the plane ``z = 0``; anything a ray meets beyond the prisms is the sky (or,
indoors, the view through a window).

World frame: metres, x right, y up, z up; angles counter-clockwise from +x.

A ray is cast in two steps. :func:`horizontal_intervals` finds, for each horizontal direction, the
interval ``[d_in, d_out]`` of horizontal distance over which the ray's ground projection lies
inside each footprint; a 3-D ray with slope ``tan(elevation)`` then meets the prism where that
interval overlaps the distances at which its height lies in ``[bottom, top]``
(:func:`slab_hits`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Cylinder", "PackedGeometry", "Prism", "box", "height_window", "horizontal_intervals", "panel", "slab_hits"]

_EPS = 1e-9


@dataclass(frozen=True)
class Prism:
    """A vertical prism over a convex polygon.

    Attributes:
        footprint: ``(V, 2)`` float vertices in counter-clockwise order, metres (V >= 3).
        bottom, top: height range, metres (``bottom < top``).
        material: name of the material (see :mod:`nightloc.synth.textures`) on every face.
        emission: tag of a light the object emits when lit (lamp shade, lit window), or None.
        u_offset: texture offset along the perimeter, metres (varies repeated materials).

    The texture coordinate ``u`` runs along the perimeter from vertex 0 (edge 0 spans
    ``0 <= u < |v1 - v0|``); ``v`` is the depth below ``top``.
    """

    footprint: np.ndarray
    bottom: float
    top: float
    material: str
    emission: str | None = None
    u_offset: float = 0.0

    def __post_init__(self) -> None:
        points = np.asarray(self.footprint, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3:
            raise ValueError(f"footprint must be (V >= 3, 2) vertices, got shape {points.shape}")
        if not self.top > self.bottom:
            raise ValueError(f"prism top {self.top} must be above bottom {self.bottom}")
        edges = np.roll(points, -1, axis=0) - points
        turns = edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]
        if np.any(turns <= 0):
            raise ValueError("footprint must be a strictly convex polygon in counter-clockwise order")
        object.__setattr__(self, "footprint", points)


@dataclass(frozen=True)
class Cylinder:
    """A vertical cylinder: centre ``(x, y)`` and radius in metres, height ``bottom..top``.

    The texture coordinate ``u`` is the arc length ``radius * angle`` counter-clockwise from +x.
    """

    center: tuple[float, float]
    radius: float
    bottom: float
    top: float
    material: str
    emission: str | None = None
    u_offset: float = 0.0

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ValueError(f"cylinder radius must be > 0, got {self.radius}")
        if not self.top > self.bottom:
            raise ValueError(f"cylinder top {self.top} must be above bottom {self.bottom}")

    def footprint_polygon(self, sides: int = 32) -> np.ndarray:
        """``(sides, 2)`` vertices of a polygon circumscribing the footprint (for shadows)."""
        angles = np.arange(sides) * 2 * np.pi / sides
        reach = self.radius / np.cos(np.pi / sides)
        return np.stack([self.center[0] + reach * np.cos(angles), self.center[1] + reach * np.sin(angles)], axis=1)


def box(x0: float, y0: float, x1: float, y1: float, bottom: float, top: float, material: str, **kw) -> Prism:
    """An axis-aligned box over ``[x0, x1] x [y0, y1]``; edge 0 is its south face (y = y0)."""
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"box corners must satisfy x0 < x1 and y0 < y1, got ({x0}, {y0}), ({x1}, {y1})")
    return Prism(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float), bottom, top, material, **kw)


def panel(
    center: tuple[float, float],
    width: float,
    depth: float,
    facing: float,
    bottom: float,
    top: float,
    material: str,
    **kw,
) -> Prism:
    """A box whose front face (edge 0, ``u`` from 0 to ``width``) faces azimuth ``facing`` (rad).

    Seen from the front, ``u`` grows left to right and texture row 0 is at the top, so an image
    texture ``width`` metres wide appears unmirrored on the front face (pictures, doors, screens).
    """
    normal = np.array([np.cos(facing), np.sin(facing)])
    along = np.array([-normal[1], normal[0]])
    c = np.asarray(center, float)
    front, back = c + normal * depth / 2, c - normal * depth / 2
    corners = [front - along * width / 2, front + along * width / 2, back + along * width / 2, back - along * width / 2]
    return Prism(np.array(corners), bottom, top, material, **kw)


#: A solid of the world: a vertical prism or a vertical cylinder.
Solid = Prism | Cylinder


@dataclass
class PackedGeometry:
    """All prisms and cylinders of a world as flat arrays, for vectorized ray casting.

    Objects ``0..n_prisms-1`` are the prisms (footprints padded to ``max_vertices`` by repeating
    the last vertex, which adds zero-length edges that no ray hits), the rest the cylinders.
    """

    objects: list[Solid]
    vertices: np.ndarray = field(init=False)  # (P, Vmax, 2) edge start points
    edge_vectors: np.ndarray = field(init=False)  # (P, Vmax, 2) edge end - start
    edge_u0: np.ndarray = field(init=False)  # (P, Vmax) perimeter coordinate of edge starts + offset
    edge_normals: np.ndarray = field(init=False)  # (P, Vmax, 2) outward unit normals
    circles: np.ndarray = field(init=False)  # (C, 3) centre x, y, radius
    circle_u0: np.ndarray = field(init=False)  # (C,) texture offsets
    bottom: np.ndarray = field(init=False)  # (O,)
    top: np.ndarray = field(init=False)  # (O,)

    def __post_init__(self) -> None:
        prisms = [o for o in self.objects if isinstance(o, Prism)]
        cylinders = [o for o in self.objects if isinstance(o, Cylinder)]
        if len(prisms) + len(cylinders) != len(self.objects):
            raise TypeError("objects must be Prism or Cylinder instances")
        if prisms and cylinders and self.objects.index(cylinders[0]) < len(prisms):
            raise ValueError("list the prisms before the cylinders")
        vmax = max((len(p.footprint) for p in prisms), default=3)
        n = len(prisms)
        self.vertices = np.zeros((n, vmax, 2))
        self.edge_vectors = np.zeros((n, vmax, 2))
        self.edge_u0 = np.zeros((n, vmax))
        self.edge_normals = np.zeros((n, vmax, 2))
        for i, p in enumerate(prisms):
            pts = p.footprint
            vec = np.roll(pts, -1, axis=0) - pts
            lengths = np.hypot(vec[:, 0], vec[:, 1])
            k = len(pts)
            self.vertices[i, :k] = pts
            self.vertices[i, k:] = pts[-1]
            self.edge_vectors[i, :k] = vec
            self.edge_u0[i, :k] = p.u_offset + np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
            self.edge_normals[i, :k] = np.stack([vec[:, 1], -vec[:, 0]], axis=1) / lengths[:, None]
        self.circles = np.array([[c.center[0], c.center[1], c.radius] for c in cylinders], float).reshape(-1, 3)
        self.circle_u0 = np.array([c.u_offset for c in cylinders], float)
        self.bottom = np.array([o.bottom for o in self.objects], float)
        self.top = np.array([o.top for o in self.objects], float)

    @property
    def n_prisms(self) -> int:
        """Number of prisms (they are objects ``0..n_prisms-1``)."""
        return len(self.vertices)

    def inside_footprint(self, x: float, y: float) -> np.ndarray:
        """``(O,)`` bool: whether the ground point ``(x, y)`` lies inside each footprint."""
        rel = np.array([x, y]) - self.vertices
        cross = self.edge_vectors[..., 0] * rel[..., 1] - self.edge_vectors[..., 1] * rel[..., 0]
        degenerate = (self.edge_vectors**2).sum(-1) == 0
        in_prism = np.all((cross >= 0) | degenerate, axis=1)
        in_circle = (x - self.circles[:, 0]) ** 2 + (y - self.circles[:, 1]) ** 2 <= self.circles[:, 2] ** 2
        return np.concatenate([in_prism, in_circle])


@dataclass
class Intervals:
    """Horizontal ray/footprint intersections, every array ``(N, O)`` for N rays and O objects.

    ``d_in``/``d_out``: horizontal distances (m) where the ray enters and leaves the footprint
    (``inf``/``-inf`` when it misses; ``d_in = 0`` when the origin is inside). ``u_in``: texture
    coordinate at the entry point; ``nx``, ``ny``: outward normal there.
    """

    d_in: np.ndarray
    d_out: np.ndarray
    u_in: np.ndarray
    nx: np.ndarray
    ny: np.ndarray


def horizontal_intervals(geometry: PackedGeometry, ox: float, oy: float, dx: np.ndarray, dy: np.ndarray) -> Intervals:
    """Where rays from ``(ox, oy)`` along unit directions ``(dx, dy)`` (each ``(N,)``) cross footprints."""
    dx = np.asarray(dx, float)[:, None, None]
    dy = np.asarray(dy, float)[:, None, None]
    # Prisms: ray o + t d against edges p + s e, s in [0, 1].
    px = geometry.vertices[None, :, :, 0] - ox
    py = geometry.vertices[None, :, :, 1] - oy
    ex = geometry.edge_vectors[None, :, :, 0]
    ey = geometry.edge_vectors[None, :, :, 1]
    denom = dx * ey - dy * ex
    safe = np.where(np.abs(denom) > _EPS, denom, 1.0)
    t = (px * ey - py * ex) / safe
    s = (px * dy - py * dx) / safe
    valid = (np.abs(denom) > _EPS) & (s >= 0.0) & (s <= 1.0) & (t > 0.0)
    t_in = np.where(valid, t, np.inf)
    t_out = np.where(valid, t, -np.inf)
    entry = np.argmin(t_in, axis=2)
    d_in_p = np.take_along_axis(t_in, entry[..., None], axis=2)[..., 0]
    d_out_p = t_out.max(axis=2)
    lengths = np.hypot(geometry.edge_vectors[..., 0], geometry.edge_vectors[..., 1])
    s_entry = np.take_along_axis(np.broadcast_to(s, t.shape), entry[..., None], axis=2)[..., 0]
    prism_index = np.arange(geometry.n_prisms)[None, :]
    u_p = geometry.edge_u0[prism_index, entry] + s_entry * lengths[prism_index, entry]
    nx_p = geometry.edge_normals[prism_index, entry, 0]
    ny_p = geometry.edge_normals[prism_index, entry, 1]
    inside = geometry.inside_footprint(ox, oy)
    inside_p = inside[: geometry.n_prisms][None, :]
    d_in_p = np.where(inside_p & np.isfinite(d_out_p), 0.0, d_in_p)

    # Cylinders: |o + t d - c|^2 = r^2.
    cx = geometry.circles[None, :, 0] - ox
    cy = geometry.circles[None, :, 1] - oy
    r = geometry.circles[None, :, 2]
    dxc, dyc = dx[:, :, 0], dy[:, :, 0]
    b = cx * dxc + cy * dyc  # distance along the ray to the closest approach
    closest2 = cx * cx + cy * cy - b * b
    disc = r * r - closest2
    root = np.sqrt(np.maximum(disc, 0.0))
    hit = (disc > 0) & (b + root > 0)
    inside_c = inside[geometry.n_prisms :][None, :]
    d_in_c = np.where(hit, np.where(inside_c, 0.0, b - root), np.inf)
    d_out_c = np.where(hit, b + root, -np.inf)
    hx = dxc * np.where(hit, d_in_c, 0.0) - cx
    hy = dyc * np.where(hit, d_in_c, 0.0) - cy
    norm = np.maximum(np.hypot(hx, hy), _EPS)
    u_c = geometry.circle_u0[None, :] + r * np.mod(np.arctan2(hy, hx), 2 * np.pi)

    return Intervals(
        d_in=np.concatenate([d_in_p, d_in_c], axis=1),
        d_out=np.concatenate([d_out_p, d_out_c], axis=1),
        u_in=np.concatenate([u_p, u_c], axis=1),
        nx=np.concatenate([nx_p, hx / norm], axis=1),
        ny=np.concatenate([ny_p, hy / norm], axis=1),
    )


def height_window(
    bottom: np.ndarray, top: np.ndarray, slope: np.ndarray, height: float
) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal distances ``(near, far)`` over which a ray's height lies in ``[bottom, top]``.

    The ray starts at height ``height`` and rises ``slope`` metres per metre of horizontal
    distance; arrays broadcast. An empty window is ``(inf, -inf)``; a level ray inside the
    height range gives ``(0, inf)`` (``near`` may be negative: the window opened behind the
    origin).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        to_bottom = (bottom - height) / slope
        to_top = (top - height) / slope
    rising = slope > 0
    level = slope == 0
    near = np.where(rising, to_bottom, to_top)
    far = np.where(rising, to_top, to_bottom)
    level_inside = (bottom <= height) & (height <= top)
    near = np.where(level, np.where(level_inside, 0.0, np.inf), near)
    far = np.where(level, np.where(level_inside, np.inf, -np.inf), far)
    return near, far


def slab_hits(
    d_in: np.ndarray, d_out: np.ndarray, bottom: np.ndarray, top: np.ndarray, slope: np.ndarray, height: float
) -> np.ndarray:
    """Horizontal distance at which a 3-D ray first meets each prism, ``inf`` where it misses.

    ``[d_in, d_out]`` is where the ray's ground track is inside the footprint (see
    :func:`horizontal_intervals`); the ray starts at ``height`` and rises ``slope`` per metre.
    Arrays broadcast, e.g. ``(1, W, K)`` intervals against ``(H, 1, 1)`` slopes.
    """
    near, far = height_window(bottom, top, slope, height)
    lo = np.maximum(np.maximum(d_in, near), 0.0)
    hi = np.minimum(d_out, far)
    return np.where(lo <= hi, lo, np.inf)


def polygon_of(obj: Solid) -> np.ndarray:
    """The footprint polygon of a prism, or a circumscribed polygon of a cylinder, ``(V, 2)``."""
    if isinstance(obj, Prism):
        return obj.footprint
    return obj.footprint_polygon()


def check_free(
    geometry: PackedGeometry, points: Sequence[tuple[float, float]] | np.ndarray, height: float, clearance: float = 0.0
) -> None:
    """Raises ValueError if a camera at ``height`` at one of ``points`` would be inside a solid."""
    for x, y in points:
        inside = geometry.inside_footprint(float(x), float(y))
        solid = inside & (geometry.bottom <= height + clearance) & (geometry.top >= height - clearance)
        if np.any(solid):
            raise ValueError(f"camera position ({x:.2f}, {y:.2f}) is inside an object of the world")
