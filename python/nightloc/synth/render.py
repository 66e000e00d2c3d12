"""Cylindrical panoramas of a synthetic world, ray cast with numpy.

Camera model (docs/design.md conventions):

* The camera sits ``world.camera_height`` metres (0.3 m) above the robot's position ``(x, y)``.
* Column ``c`` of a ``W``-column panorama looks along world azimuth ``heading - 2*pi*c/W``:
  column 0 straight ahead, moving right in the image turns clockwise.
* Rows span a fixed elevation range, linearly in angle: the top edge of row 0 is
  ``elevation_top_deg`` (+50 degrees by default), the bottom edge of the last row
  ``elevation_bottom_deg`` (-30 degrees); row ``r`` looks at elevation
  ``top - (r + 0.5) * (top - bottom) / H``.

Each pixel is the mean of ``oversample_x x oversample_y`` rays (box anti-aliasing; by default
2 x 1, which makes the rays about as far apart across as down: 0.94 x 0.83 degrees). For every ray
the first solid it meets is found exactly (see :mod:`nightloc.synth.geometry`), so parallax and
occlusion are real; rays that miss every solid meet the ground plane (downwards) or the sky.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import MAX_CAMERA_RAYS, MAX_CAMERA_SIDE
from .geometry import height_window, horizontal_intervals
from .lighting import Lighting, shade_objects
from .sensor import Exposure, capture
from .world import World

__all__ = ["Camera", "RayHits", "cast_rays", "column_azimuths", "render_panorama", "render_radiance", "row_elevations"]

# What a ray hit, in RayHits.kind.
SKY, GROUND, OBJECT = 0, 1, 2


@dataclass(frozen=True)
class Camera:
    """Panorama size and optics.

    Attributes:
        width, height: panorama size in pixels (default 192 x 96, before preparation).
        elevation_top_deg, elevation_bottom_deg: elevation of the top edge of the first row and
            the bottom edge of the last row, degrees.
        oversample_x, oversample_y: rays per pixel across and down (anti-aliasing).
    """

    width: int = 192
    height: int = 96
    elevation_top_deg: float = 50.0
    elevation_bottom_deg: float = -30.0
    oversample_x: int = 2
    oversample_y: int = 1

    def __post_init__(self) -> None:
        for name in ("width", "height", "oversample_x", "oversample_y"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"camera {name} must be a positive int, got {value!r}")
        if max(self.width, self.height) > MAX_CAMERA_SIDE:
            raise ValueError(
                f"camera of {self.width}x{self.height} pixels is too large: at most {MAX_CAMERA_SIDE} pixels along a "
                f"side (MAX_CAMERA_SIDE)"
            )
        rays = self.width * self.oversample_x * self.height * self.oversample_y
        if rays > MAX_CAMERA_RAYS:
            raise ValueError(
                f"camera of {self.width}x{self.height} pixels at {self.oversample_x}x{self.oversample_y} oversampling "
                f"casts {rays} rays per frame, more than {MAX_CAMERA_RAYS} (MAX_CAMERA_RAYS; each takes about 180 "
                f"bytes while a frame renders)"
            )
        if not (-90.0 < self.elevation_bottom_deg < self.elevation_top_deg < 90.0):
            raise ValueError("camera elevations must satisfy -90 < bottom < top < 90 degrees")


def column_azimuths(heading: float, width: int, oversample: int = 1) -> np.ndarray:
    """World azimuth (rad) of each ray column: ``heading - 2*pi*c/width`` at column centres ``c``.

    With ``oversample = s`` the ``s`` rays of column ``c`` sit at ``c + (j + 0.5)/s - 0.5``.
    """
    sub = (np.arange(width * oversample) + 0.5) / oversample - 0.5
    return heading - 2.0 * np.pi * sub / width


def row_elevations(camera: Camera) -> np.ndarray:
    """Elevation (rad) of each ray row, top to bottom, ``(height * oversample_y,)``."""
    n = camera.height * camera.oversample_y
    top, bottom = np.radians(camera.elevation_top_deg), np.radians(camera.elevation_bottom_deg)
    return top - (np.arange(n) + 0.5) * (top - bottom) / n


@dataclass
class RayHits:
    """What every ray of a panorama meets; arrays ``(rows, cols)`` at the oversampled size.

    ``kind``: 0 sky, 1 ground, 2 object; ``obj``: object index (-1 otherwise); ``distance``:
    horizontal distance to the hit (m, inf for the sky); ``x``, ``y``, ``z``: the world point
    hit; ``nx``, ``ny``, ``nz``: the outward surface normal there; ``tex_u``, ``tex_v``: texture
    coordinates in metres (sides: perimeter position and depth below the top; caps: x and y);
    ``azimuth`` ``(cols,)`` and ``elevation`` ``(rows,)`` of the rays.
    """

    kind: np.ndarray
    obj: np.ndarray
    distance: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    nz: np.ndarray
    tex_u: np.ndarray
    tex_v: np.ndarray
    azimuth: np.ndarray
    elevation: np.ndarray


def cast_rays(
    world: World, x: float, y: float, heading: float, camera: Camera = Camera(), height: float | None = None
) -> RayHits:
    """Casts every ray of the panorama taken at ``(x, y)`` with ``heading`` (rad), the camera
    ``height`` metres above the ground (default the world's ``camera_height``)."""
    geometry = world.geometry
    height = world.camera_height if height is None else float(height)
    azimuth = column_azimuths(heading, camera.width, camera.oversample_x)
    elevation = row_elevations(camera)
    slope = np.tan(elevation)
    dx, dy = np.cos(azimuth), np.sin(azimuth)
    spans = horizontal_intervals(geometry, x, y, dx, dy)  # (cols, O)

    # Keep, per column, only the objects the ray's ground track crosses, nearest first.
    crossed = np.isfinite(spans.d_in)
    k = max(1, int(crossed.sum(axis=1).max()))
    order = np.argsort(spans.d_in, axis=1, kind="stable")[:, :k]  # (cols, K)
    cols = len(azimuth)
    flat = (np.arange(cols)[:, None] * spans.d_in.shape[1] + order).ravel()
    pick = lambda a: a.ravel()[flat].reshape(cols, k)  # noqa: E731
    d_in = pick(spans.d_in).astype(np.float32)
    d_out = pick(spans.d_out).astype(np.float32)

    # Where each row's ray is inside each object's height range, (rows, O), then per (row, col, k).
    near, far = height_window(geometry.bottom[None, :], geometry.top[None, :], slope[:, None], height)
    lo = np.maximum(near.astype(np.float32)[:, order], d_in[None])  # (rows, cols, K); d_in >= 0
    hi = np.minimum(far.astype(np.float32)[:, order], d_out[None])
    lo[lo > hi] = np.inf
    best = np.argmin(lo, axis=2)
    rows = len(elevation)
    dist = np.take_along_axis(lo, best[..., None], axis=2)[..., 0].astype(np.float64)
    col_index = np.broadcast_to(np.arange(cols)[None, :], (rows, cols))
    obj = order[col_index, best]

    with np.errstate(divide="ignore"):
        ground_dist = np.where(slope < 0, -height / slope, np.inf)[:, None]
    is_object = np.isfinite(dist) & (dist < ground_dist)
    is_ground = ~is_object & np.isfinite(ground_dist)
    kind = np.where(is_object, OBJECT, np.where(is_ground, GROUND, SKY)).astype(np.int8)
    dist = np.where(is_object, dist, np.where(is_ground, ground_dist, np.inf))

    safe = np.where(np.isfinite(dist), dist, 0.0)
    px = x + safe * dx[None, :]
    py = y + safe * dy[None, :]
    pz = np.where(is_ground, 0.0, height + safe * slope[:, None])

    # Side face where the hit is at the footprint's entry, else the top or bottom cap.
    entry = d_in[col_index, best]
    side = is_object & (dist <= entry)
    nx = np.where(side, pick(spans.nx)[col_index, best], 0.0)
    ny = np.where(side, pick(spans.ny)[col_index, best], 0.0)
    nz = np.where(side, 0.0, np.where(slope[:, None] > 0, -1.0, 1.0))
    nz[is_ground] = 1.0
    tex_u = np.where(side, pick(spans.u_in)[col_index, best], px)
    tex_v = np.where(side, geometry.top[obj] - pz, py)
    return RayHits(kind, np.where(is_object, obj, -1), dist, px, py, pz, nx, ny, nz, tex_u, tex_v, azimuth, elevation)


class _Atlas:
    """All of a world's material textures in one flat array, for one gather per frame."""

    def __init__(self, world: World):
        textures = [world.materials[name] for name in world.material_names]
        self.rows = np.array([t.albedo.shape[0] for t in textures], np.int64)
        self.cols = np.array([t.albedo.shape[1] for t in textures], np.int64)
        self.ppm = np.array([t.pixels_per_metre for t in textures], np.float64)
        sizes = self.rows * self.cols
        self.offset = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        self.albedo = np.concatenate([t.albedo.reshape(-1, 3) for t in textures]).astype(np.float32) / 255.0
        emissive = [t.albedo if t.emissive is None else t.emissive for t in textures]
        self.emissive = np.concatenate([e.reshape(-1, 3) for e in emissive]).astype(np.float32) / 255.0

    def index(self, material: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Flat pixel index of texture coordinates ``(u, v)`` (metres) on each point's material."""
        ppm = self.ppm[material]
        col = np.mod(np.floor(u * ppm).astype(np.int64), self.cols[material])
        row = np.mod(np.floor(v * ppm).astype(np.int64), self.rows[material])
        return self.offset[material] + row * self.cols[material] + col


_ATLASES: dict[int, tuple[World, _Atlas]] = {}


def _atlas(world: World) -> _Atlas:
    cached = _ATLASES.get(id(world))
    if cached is None or cached[0] is not world:
        if len(_ATLASES) > 8:
            _ATLASES.clear()
        cached = (world, _Atlas(world))
        _ATLASES[id(world)] = cached
    return cached[1]


def render_radiance(
    world: World,
    lighting: Lighting,
    x: float,
    y: float,
    heading: float,
    camera: Camera = Camera(),
    height: float | None = None,
) -> np.ndarray:
    """Linear scene radiance of the panorama at ``(x, y, heading)``: ``(height, width, 3)`` float32
    RGB (``height``: the camera's above the ground, default the world's)."""
    hits = cast_rays(world, x, y, heading, camera, height)
    rows, cols = hits.kind.shape
    kind = hits.kind.ravel()
    radiance = np.empty((rows * cols, 3), np.float32)
    sky = np.flatnonzero(kind == SKY)
    if sky.size:
        radiance[sky] = lighting.sky.sample(hits.azimuth[sky % cols], hits.elevation[sky // cols])
    ground = np.flatnonzero(kind == GROUND)
    radiance[ground] = lighting.ground.sample(hits.x.ravel()[ground], hits.y.ravel()[ground])
    solid = np.flatnonzero(kind == OBJECT)
    if solid.size:
        obj = hits.obj.ravel()[solid]
        atlas = _atlas(world)
        texel = atlas.index(world.material_index[obj], hits.tex_u.ravel()[solid], hits.tex_v.ravel()[solid])
        points = np.stack([a.ravel()[solid] for a in (hits.x, hits.y, hits.z)], axis=1)
        normals = np.stack([a.ravel()[solid] for a in (hits.nx, hits.ny, hits.nz)], axis=1)
        shaded = shade_objects(lighting, atlas.albedo[texel], points, normals)
        glow = np.array([lighting.glow.get(o.emission, 0.0) if o.emission else 0.0 for o in world.objects], np.float32)[
            obj
        ]
        if glow.any():
            shaded += atlas.emissive[texel] * glow[:, None]
        radiance[solid] = shaded
    radiance = radiance.reshape(rows, cols, 3)
    sy, sx = camera.oversample_y, camera.oversample_x
    if sx * sy > 1:
        total = np.zeros((camera.height, camera.width, 3), np.float32)
        for i in range(sy):
            for j in range(sx):
                total += radiance[i::sy, j::sx]
        radiance = total / np.float32(sx * sy)
    return radiance


def render_panorama(
    world: World,
    lighting: Lighting,
    exposure: Exposure,
    x: float,
    y: float,
    heading: float,
    camera: Camera = Camera(),
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """The camera image at ``(x, y, heading)``: ``(height, width, 3)`` uint8 BGR.

    ``rng`` draws the sensor's shot and read noise; None gives the noiseless image.
    """
    return capture(render_radiance(world, lighting, x, y, heading, camera), exposure, rng)
