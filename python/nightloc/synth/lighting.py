"""Day and night lighting: sun, sky, lamps with fall-off, cast shadows on the ground.

Radiance is in arbitrary linear units in which a white surface facing the noon sun reads about
3 and the day sky about 1-2. Surfaces are Lambertian: ``radiance = albedo * irradiance``, plus
``glow * emissive`` for lamp shades, lit windows and the oven light while their light is on. Irradiance is

* ``ambient * (1 - w + w * n_z)``: diffuse light of the sky (``w = 0.45``) or, indoors, light
  bounced around the room (``w = 0.25``), brightest on surfaces facing up;
* the sun, ``sun * max(0, n . s)`` for unit direction ``s`` towards the sun (day only). Outdoors
  it lights every surface; indoors it only reaches the floor, through the window openings;
* each lamp that is on: ``power * max(0, n . l) / d**2`` for the unit direction ``l`` and
  distance ``d`` to the lamp (inverse-square fall-off).

Cast shadows are exact on the ground: each prism's shadow from the sun (or a lamp) is the convex
hull of its vertices projected along the light rays, rasterized into a ground light map once per
lighting. Walls and furniture get no cast shadows (only the ``n . s`` term).

Day and night differ as in the paper's datasets: by day the sun (its direction drawn from the
seed) throws shadows and, indoors, sun patches through the windows, and the house lights are on;
at night the sky is dark and only the lamps the world switches on for ``"night"`` light the scene,
so shading, shadows and bright spots all move.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .geometry import Cylinder, polygon_of
from .textures import fbm, value_noise
from .world import GroundMap, LightSource, World

__all__ = [
    "CONDITIONS",
    "MOON_IRRADIANCE",
    "Lighting",
    "SkyMap",
    "ground_irradiance",
    "make_lighting",
    "make_night_lighting",
    "shade_objects",
]

CONDITIONS: tuple[str, ...] = ("day", "night")


@dataclass(frozen=True)
class SkyMap:
    """Radiance of the sky (and, indoors, of the view out of the windows) by direction.

    ``values[row, col]``: row 0 at elevation +90 degrees down to ``-20`` degrees in the last row,
    columns spanning azimuth 0..2*pi counter-clockwise from +x; ``(rows, cols, 3)`` float32.
    """

    values: np.ndarray
    low_deg: float = -20.0

    def sample(self, azimuth: np.ndarray, elevation: np.ndarray) -> np.ndarray:
        """Nearest-cell radiance ``(N, 3)`` in directions ``azimuth``, ``elevation`` (rad, ``(N,)``)."""
        rows, cols = self.values.shape[:2]
        c = (np.mod(azimuth, 2 * np.pi) * (cols / (2 * np.pi))).astype(np.int64) % cols
        span = np.radians(90.0 - self.low_deg)
        r = np.clip(((np.radians(90.0) - elevation) * (rows / span)).astype(np.int64), 0, rows - 1)
        return self.values[r, c]


@dataclass(frozen=True)
class Lighting:
    """One lighting condition of one world.

    Attributes:
        condition: ``"day"`` or ``"night"``.
        ambient: RGB diffuse irradiance on an upward-facing surface.
        ambient_up_weight: how much more diffuse light faces up than sideways (0.45 outdoors,
            0.25 indoors where light bounces off walls and ceiling).
        sun_direction: unit vector ``(x, y, z)`` towards the sun (by day) or the moon (a moonlit
            night), or None.
        sun: RGB irradiance of direct sun (or moon) light on a surface facing it.
        sun_on_surfaces: False indoors (sun and moon light reach the floor only through the windows).
        lamps: the lamps that are on.
        glow: radiance gain of glowing objects by emission tag (their albedo times this).
        sky: radiance of the sky / outside view.
        ground: radiance of the ground plane (albedo times irradiance, shadows included).
    """

    condition: str
    ambient: np.ndarray
    ambient_up_weight: float
    sun_direction: np.ndarray | None
    sun: np.ndarray
    sun_on_surfaces: bool
    lamps: tuple[LightSource, ...]
    glow: dict[str, float]
    sky: SkyMap
    ground: GroundMap


def _sky_map(rng: np.random.Generator, condition: str, indoor: bool, sun_direction: np.ndarray | None) -> SkyMap:
    rows, cols = 220, 720  # 0.5 degree cells from +90 to -20 degrees elevation
    elevation = np.radians(90.0 - (np.arange(rows) + 0.5) * 110.0 / rows)[:, None]
    azimuth = ((np.arange(cols) + 0.5) * 2 * np.pi / cols)[None, :]
    up = np.clip(np.sin(elevation), 0.0, 1.0) ** 0.5
    clouds = fbm(rng, rows, cols, 4, 12, octaves=5)
    cover = np.clip((clouds - 0.5) * 3.0, 0.0, 1.0)[..., None]
    if condition == "day":
        horizon, zenith = np.array([1.6, 1.7, 1.8], np.float32), np.array([0.45, 0.75, 1.5], np.float32)
        sky = horizon + (zenith - horizon) * up[..., None]
        sky = sky * (1 - cover) + np.array([2.2, 2.2, 2.25], np.float32) * (0.75 + 0.25 * clouds[..., None]) * cover
        if sun_direction is not None:
            cos_angle = (
                np.cos(elevation) * np.cos(azimuth) * sun_direction[0]
                + np.cos(elevation) * np.sin(azimuth) * sun_direction[1]
                + np.sin(elevation) * sun_direction[2]
            )
            sky = sky + (2.5 * np.exp((cos_angle - 1) / 0.01) + 40.0 * (cos_angle > np.cos(np.radians(0.8))))[..., None]
        below = (
            np.array([0.25, 0.35, 0.18], np.float32) * (0.6 + 0.8 * value_noise(rng, rows, cols, 22, 180))[..., None]
        )
    else:
        horizon, zenith = np.array([0.010, 0.008, 0.006], np.float32), np.array([0.0015, 0.002, 0.004], np.float32)
        glow = np.exp(-np.clip(elevation, 0, None) / np.radians(12.0))
        sky = zenith + (horizon - zenith) * glow[..., None] + np.array([0.004, 0.003, 0.003], np.float32) * cover
        stars = (rng.random((rows, cols)) < 0.0015) & (elevation > np.radians(8.0))
        sky = sky + (stars * rng.uniform(0.01, 0.06, (rows, cols)))[..., None]
        below = np.array([0.002, 0.002, 0.002], np.float32) * (0.5 + value_noise(rng, rows, cols, 22, 180))[..., None]
        if indoor:  # street lights seen through the windows
            spots = (rng.random((rows, cols)) < 0.002) & (np.abs(elevation) < np.radians(6.0))
            sky = sky + (spots * 0.5)[..., None]
    sky = np.where((elevation < 0)[..., None], below, sky)
    return SkyMap(np.ascontiguousarray(sky, dtype=np.float32))


def _rasterize_hull(mask: np.ndarray, ground: GroundMap, points: np.ndarray) -> None:
    """Fills the convex hull of ground points ``(N, 2)`` metres into ``mask`` (uint8, ground grid)."""
    shift = 4
    pix = np.stack(
        [
            (points[:, 0] - ground.x0) * ground.pixels_per_metre - 0.5,
            (points[:, 1] - ground.y0) * ground.pixels_per_metre - 0.5,
        ],
        axis=1,
    )
    limit = 4 * max(mask.shape)
    pix = np.clip(pix, -limit, limit)
    hull = cv2.convexHull(np.round(pix * (1 << shift)).astype(np.int32))
    cv2.fillConvexPoly(mask, hull, 255, lineType=cv2.LINE_AA, shift=shift)


def _shadow_mask(
    world: World,
    ground: GroundMap,
    light_point: np.ndarray | None,
    sun_direction: np.ndarray | None,
    skip_tag: str | None,
) -> np.ndarray:
    """Float32 ground-grid map of light reaching the ground (1 lit, 0 shadowed) for one light."""
    mask = np.zeros(ground.values.shape[:2], np.uint8)
    for obj in world.objects:
        if skip_tag is not None and obj.emission == skip_tag:
            continue
        footprint = polygon_of(obj)
        bottom, top = obj.bottom, obj.top
        if sun_direction is not None:
            offset = -sun_direction[:2] / sun_direction[2]
            points = np.concatenate([footprint + bottom * offset, footprint + top * offset])
        else:
            assert light_point is not None, "a shadow needs the sun's direction or the light's position"
            lx, ly, lz = light_point
            if isinstance(obj, Cylinder):
                contains = (lx - obj.center[0]) ** 2 + (ly - obj.center[1]) ** 2 <= obj.radius**2
            else:
                rel = np.array([lx, ly]) - footprint
                edges = np.roll(footprint, -1, axis=0) - footprint
                contains = bool(np.all(edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] >= 0))
            if contains or bottom >= lz - 0.01:
                continue  # the lamp's own fixture, or an object above the lamp
            top = min(top, lz - 0.01)
            layers = []
            for z in (bottom, top):
                factor = min(lz / (lz - z), 60.0)
                layers.append(np.array([lx, ly]) + (footprint - np.array([lx, ly])) * factor)
            points = np.concatenate(layers)
        _rasterize_hull(mask, ground, points)
    lit = 1.0 - mask.astype(np.float32) / 255.0
    return cv2.GaussianBlur(lit, (0, 0), 1.2)


def ground_irradiance(
    world: World,
    ambient: np.ndarray,
    sun_direction: np.ndarray | None = None,
    sun: np.ndarray | None = None,
    lamps: Sequence[tuple[str, LightSource]] = (),
) -> GroundMap:
    """Irradiance of the ground plane on the grid of ``world.ground``, shadows included.

    ``ambient + sun * s_z * lit_sun + sum(power * (h / d) / d**2 * lit_lamp)`` for a lamp at
    height ``h`` and distance ``d``; ``lit_*`` is 1 outside the light's cast shadows and 0 inside
    (slightly blurred at the edges). ``lamps`` are ``(name, lamp)`` pairs: objects whose
    emission tag is the lamp's name (its own shade) cast no shadow of it.
    """
    grid = world.ground
    irradiance = np.empty_like(grid.values)
    irradiance[:] = np.asarray(ambient, np.float32)
    if sun_direction is not None:
        lit = _shadow_mask(world, grid, None, np.asarray(sun_direction, float), None)
        irradiance += (np.asarray(sun, np.float32) * np.float32(sun_direction[2]))[None, None, :] * lit[..., None]
    xs, ys = grid.cell_centres()
    for name, lamp in lamps:
        lx, ly, lz = lamp.position
        d2 = (xs - lx) ** 2 + (ys - ly) ** 2 + lz * lz
        cosine = lz / np.sqrt(d2)
        lit = _shadow_mask(world, grid, np.array(lamp.position, float), None, name)
        irradiance += (np.asarray(lamp.power, np.float32)[None, None, :] * (cosine / d2 * lit)[..., None]).astype(
            np.float32
        )
    return GroundMap(np.ascontiguousarray(irradiance, dtype=np.float32), grid.x0, grid.y0, grid.pixels_per_metre)


def make_lighting(world: World, condition: str, seed: int = 0) -> Lighting:
    """The ``"day"`` or ``"night"`` lighting of ``world``; the sun's direction comes from ``seed``.

    By day the sun stands 25-45 degrees high (indoors: in the south, so it shines through the
    south windows) at an azimuth drawn from ``seed``. Results are cached per world object (the
    last few are reused); treat them as read-only.
    """
    if condition not in CONDITIONS:
        raise ValueError(f"unknown lighting condition {condition!r}; choose one of {CONDITIONS}")
    key = (id(world), condition, int(seed))
    cached = _LIGHTING_CACHE.get(key)
    if cached is not None and cached[0] is world:
        return cached[1]
    lighting = _make_lighting(world, condition, int(seed))
    if len(_LIGHTING_CACHE) >= 8:
        _LIGHTING_CACHE.pop(next(iter(_LIGHTING_CACHE)))
    _LIGHTING_CACHE[key] = (world, lighting)
    return lighting


_LIGHTING_CACHE: dict[tuple, tuple] = {}


def _make_lighting(world: World, condition: str, seed: int) -> Lighting:
    rng = np.random.default_rng([int(seed), 3, CONDITIONS.index(condition), len(world.name)])
    lamps = tuple((name, lamp) for name, lamp in sorted(world.lights.items()) if condition in lamp.conditions)
    glow = {name: lamp.glow for name, lamp in lamps}
    if condition == "day":
        if world.indoor:
            azimuth = np.radians(rng.uniform(-125.0, -55.0))
            elevation = np.radians(rng.uniform(25.0, 38.0))
            ambient = np.array([0.45, 0.45, 0.44], np.float32)
        else:
            azimuth = rng.uniform(-np.pi, np.pi)
            elevation = np.radians(rng.uniform(28.0, 45.0))
            ambient = np.array([0.55, 0.62, 0.75], np.float32)
        sun_direction = np.array(
            [np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)]
        )
        sun = np.array([3.0, 2.85, 2.6], np.float32)
    else:
        sun_direction = None
        sun = np.zeros(3, np.float32)
        ambient = np.array([0.0015, 0.0018, 0.0025] if not world.indoor else [0.003, 0.003, 0.0035], np.float32)
    sky = _sky_map(rng, condition, world.indoor, sun_direction)
    irradiance = ground_irradiance(world, ambient, sun_direction, sun, lamps)
    ground = GroundMap(
        world.ground.values * irradiance.values, irradiance.x0, irradiance.y0, irradiance.pixels_per_metre
    )
    return Lighting(
        condition,
        ambient,
        0.25 if world.indoor else 0.45,
        sun_direction,
        sun,
        not world.indoor,
        tuple(lamp for _, lamp in lamps),
        glow,
        sky,
        ground,
    )


#: Irradiance of a full moon on a surface facing it, in the worlds' radiance units. A lamp's
#: ``power`` is its irradiance 1 m away: the garden's porch lamp (0.55, an 800-lumen bulb, about 64
#: lux at 1 m) sets about 115 lux per unit, and a full moon gives about 0.25 lux.
MOON_IRRADIANCE = 0.0022
#: Moonlight's colour (relative RGB): sunlight reflected by grey rock, a little redder.
MOON_COLOUR = (1.0, 0.93, 0.82)
#: Indoors at night, the share of the room's diffuse light that comes from outside (street lights
#: and the sky through the windows); the rest is the lamps' light bounced off walls and ceiling.
INDOOR_OUTSIDE_SHARE = 0.2
#: Diffuse light per unit of direct moonlight on a surface facing the moon: scattered by the sky
#: outdoors (the day's ratio of sky light to sun), bounced off the floor patches indoors.
_MOON_DIFFUSE = {False: 0.2, True: 0.05}


def make_night_lighting(
    world: World,
    seed: int = 0,
    *,
    moon: float = 0.0,
    moon_direction: Sequence[float] | np.ndarray | None = None,
    lamp_bounce: float = 1.0,
) -> Lighting:
    """A night of ``world`` lit by the lamps its ``lights`` switch on for ``"night"`` and,
    optionally, the moon.

    The dark sky (glow, clouds, stars) is the usual night's (:func:`make_lighting` with
    ``"night"``, same ``seed``). The moon is a second sun, ``moon * MOON_IRRADIANCE`` on a surface
    facing it, with exact cast shadows on the ground (indoors on the floor through the windows
    only); its light scattered by the sky adds diffuse light, and the sky brightens like a day sky
    scaled by the moon's irradiance, with the moon's disc.

    Args:
        world: the world, with the lamps of this night switched on (``"night"`` in their
            ``conditions``).
        seed: the night sky's stars and clouds.
        moon: the moon's light: 0 none (a moonless night), 1 a full moon.
        moon_direction: unit vector ``(x, y, z)`` towards the moon (``z > 0``); needed when
            ``moon > 0``.
        lamp_bounce: indoors, the lamps' bounced diffuse light relative to the world's usual night
            (0 = every lamp off, 1 = the usual lamps); :data:`INDOOR_OUTSIDE_SHARE` of the room's
            diffuse light comes from outside and stays.

    With ``moon = 0`` and ``lamp_bounce = 1`` this is :func:`make_lighting` ``(world, "night", seed)``.
    """
    if not (np.isfinite(moon) and 0.0 <= moon <= 10.0):
        raise ValueError(f"moon must be in [0, 10] (1 = a full moon), got {moon!r}")
    if not (np.isfinite(lamp_bounce) and lamp_bounce >= 0.0):
        raise ValueError(f"lamp_bounce must be >= 0, got {lamp_bounce!r}")
    usual = make_lighting(world, "night", seed)
    ambient = usual.ambient
    if world.indoor and lamp_bounce != 1.0:
        ambient = (ambient * np.float32(INDOOR_OUTSIDE_SHARE + (1.0 - INDOOR_OUTSIDE_SHARE) * lamp_bounce)).astype(
            np.float32
        )
    if moon == 0.0:
        if ambient is usual.ambient:
            return usual
        direction, moonlight, sky = None, np.zeros(3, np.float32), usual.sky
    else:
        if moon_direction is None:
            raise ValueError("a moonlit night needs moon_direction, a unit vector towards the moon")
        direction = np.asarray(moon_direction, dtype=np.float64)
        if direction.shape != (3,) or not np.all(np.isfinite(direction)) or direction[2] <= 0:
            raise ValueError(f"moon_direction must be a finite (x, y, z) vector with z > 0, got {moon_direction!r}")
        direction = direction / np.linalg.norm(direction)
        moonlight = (np.float32(moon * MOON_IRRADIANCE) * np.asarray(MOON_COLOUR, np.float32)).astype(np.float32)
        ambient = (ambient + moonlight * np.float32(_MOON_DIFFUSE[world.indoor])).astype(np.float32)
        sky = SkyMap(_moonlit_sky(usual.sky.values, direction, float(moon * MOON_IRRADIANCE)), usual.sky.low_deg)
    lamps = tuple((name, lamp) for name, lamp in sorted(world.lights.items()) if "night" in lamp.conditions)
    irradiance = ground_irradiance(world, ambient, direction, moonlight, lamps)
    ground = GroundMap(
        world.ground.values * irradiance.values, irradiance.x0, irradiance.y0, irradiance.pixels_per_metre
    )
    return Lighting(
        "night",
        ambient,
        usual.ambient_up_weight,
        direction,
        moonlight,
        not world.indoor,
        tuple(lamp for _, lamp in lamps),
        {name: lamp.glow for name, lamp in lamps},
        sky,
        ground,
    )


def _moonlit_sky(night_sky: np.ndarray, direction: np.ndarray, irradiance: float) -> np.ndarray:
    """The night sky ``(rows, cols, 3)`` plus scattered moonlight: the day sky's gradient and the
    glow round the disc scaled by ``irradiance / sun`` (the day's sun gives 3), and the disc."""
    rows, cols = night_sky.shape[:2]
    elevation = np.radians(90.0 - (np.arange(rows) + 0.5) * 110.0 / rows)[:, None]
    azimuth = ((np.arange(cols) + 0.5) * 2 * np.pi / cols)[None, :]
    up = np.clip(np.sin(elevation), 0.0, 1.0) ** 0.5
    horizon, zenith = np.array([1.6, 1.7, 1.8], np.float32), np.array([0.45, 0.75, 1.5], np.float32)
    cos_angle = (
        np.cos(elevation) * np.cos(azimuth) * direction[0]
        + np.cos(elevation) * np.sin(azimuth) * direction[1]
        + np.sin(elevation) * direction[2]
    )
    scattered = horizon + (zenith - horizon) * up[..., None]
    scattered = (
        scattered + (2.5 * np.exp((cos_angle - 1) / 0.01) + 40.0 * (cos_angle > np.cos(np.radians(0.8))))[..., None]
    )
    below = np.array([0.2, 0.28, 0.14], np.float32)  # distant ground by day: the sun's light reflected
    scattered = np.where((elevation < 0)[..., None], below, scattered)
    return np.ascontiguousarray(night_sky + np.float32(irradiance / 3.0) * scattered, dtype=np.float32)


def shade_objects(lighting: Lighting, albedo: np.ndarray, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Reflected radiance of object surface points, ``(N, 3)`` float32 (glow not included).

    Args:
        albedo: ``(N, 3)`` linear albedo in [0, 1].
        points: ``(N, 3)`` world points, metres.
        normals: ``(N, 3)`` unit outward normals.
    """
    albedo = np.asarray(albedo, np.float32)
    points = np.asarray(points, np.float32)
    normals = np.asarray(normals, np.float32)
    nz = normals[:, 2:3]
    up_weight = lighting.ambient_up_weight
    irradiance = lighting.ambient[None, :] * np.clip(1.0 - up_weight + up_weight * nz, 0.1, 1.0)
    if lighting.sun_direction is not None and lighting.sun_on_surfaces:
        facing = np.clip(normals @ lighting.sun_direction.astype(np.float32), 0.0, None)[:, None]
        irradiance = irradiance + lighting.sun[None, :] * facing
    for lamp in lighting.lamps:
        to_lamp = np.asarray(lamp.position, np.float32)[None, :] - points
        d2 = np.maximum(np.einsum("ij,ij->i", to_lamp, to_lamp), np.float32(0.15**2))
        cosine_over_d2 = np.clip(np.einsum("ij,ij->i", to_lamp, normals), 0.0, None) / (d2 * np.sqrt(d2))
        irradiance = irradiance + np.asarray(lamp.power, np.float32)[None, :] * cosine_over_d2[:, None]
    return albedo * irradiance
