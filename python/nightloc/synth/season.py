"""A season of nights: one outdoor world night after night, its light and its scene changing.

A robot that mows every night for months sees the moon wax and wane, clouds and rain, a lamp
that burns out, lanterns that are put up; the grass grows and is mowed (the stripes change
direction), leaves fall, chairs move, a playhouse appears and a bench goes. :func:`plan_season`
draws such a season for the garden or the large garden from a seed, night by night
(:class:`SeasonNight`), :func:`season_world` builds a night's world from it, and
:func:`season_drives` plans the night's drives: every night a re-drive of the day path with its
own wheel odometry (the log a map learns from), every ``test_every`` nights a test drive on the
world's other path. ``nightloc synth --season N`` renders them
(:func:`nightloc.synth.dataset.make_dataset`, ``season=``).

Per night (its own generator, so a longer season begins with the nights of a shorter one):

==============  ==================================================================================
moon            the phase advances a synodic month of :data:`SYNODIC_MONTH` nights; the moon is up
                from phase 0.1 to 0.8 at the robot's hour, moving from west through south to east;
                its light is the lit fraction times the clear sky
clouds, rain    cloud cover 0-1 dims the moon; a rainy night is overcast and wets the ground
                (:data:`WET_ALBEDO`), which stays wet the night after
darkness        a foggy night (:data:`FOG_DARKNESS`) lowers the photons as ``darker`` does
lamps           the usual lamps; from a night drawn in :data:`LANTERN_NIGHTS` garden lanterns
                (:func:`~nightloc.synth.nights.switch_lamps`) stand round the lawn for good; the
                house's lamps and lit window are off for three nights in a row (:data:`AWAY_NIGHTS`)
grass           mowed every :data:`MOWING_INTERVAL` nights to :data:`MOWN_CM`, growing
                :data:`GROWTH_CM_PER_NIGHT` a night; each mowing turns the stripes by 90 degrees,
                their contrast fading as the grass grows; taller grass is darker
leaves          fall from a night drawn in :data:`AUTUMN_NIGHTS` on, piling up; mowing shreds most
furniture       two chairs and a table on the lawn's edge, moved on about one night in five; a
                wheelbarrow left out on some nights
objects         a playhouse put up on a night drawn in :data:`PLAYHOUSE_NIGHTS` (it stays); the
                garden's bench (the large garden's compost box) taken away on a night drawn in
                :data:`REMOVAL_NIGHTS`
==============  ==================================================================================

Bad nights (``bad``, :data:`BAD_NIGHTS`) replace a night's re-drive: ``covered`` (the lens
covered: :data:`COVERED_TRANSMISSION` of the light reaches the sensor, nearly black noisy
frames), ``kidnapped`` (the robot carried halfway along its path at half-time; its wheel odometry
shows no motion for the carry) and ``other_garden`` (the night driven in another garden: the world
built from another seed and mirrored, :func:`other_garden`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace

import numpy as np

from .geometry import Cylinder, Prism, Solid
from .nights import switch_lamps
from .paths import TraversePlan, plan_night_drives
from .scene import GroundMap, World
from .world import ALL_WORLDS, build_world

__all__ = [
    "AUTUMN_NIGHTS",
    "AWAY_NIGHTS",
    "BAD_NIGHTS",
    "LANTERN_NIGHTS",
    "MOWING_INTERVAL",
    "PLAYHOUSE_NIGHTS",
    "REMOVAL_NIGHTS",
    "SEASON_WORLDS",
    "SYNODIC_MONTH",
    "SeasonNight",
    "other_garden",
    "parse_bad_nights",
    "plan_season",
    "season_drives",
    "season_traverse_names",
    "season_world",
]

#: The worlds a season is drawn for (the outdoor ones: a lawn that grows).
SEASON_WORLDS: tuple[str, ...] = ("garden", "large_garden")
#: The kinds of bad night.
BAD_NIGHTS: tuple[str, ...] = ("covered", "kidnapped", "other_garden")
#: Nights of one lunar cycle.
SYNODIC_MONTH = 29.53
#: The lawn is mowed every this many nights (the first mowing on a night drawn in 1..7).
MOWING_INTERVAL = 7
#: Grass height after mowing (cm) and its growth per night (cm).
MOWN_CM = 3.0
GROWTH_CM_PER_NIGHT = 0.4
#: Mowing stripes: brightness factor 1 +- STRIPE_CONTRAST right after mowing (the day map's lawn,
#: mowed along x), fading by e every STRIPE_FADE_NIGHTS nights; stripes STRIPE_WIDTH_M wide.
STRIPE_CONTRAST = 0.12
STRIPE_FADE_NIGHTS = 5.0
STRIPE_WIDTH_M = 0.55
#: Albedo of wet ground relative to dry.
WET_ALBEDO = 0.62
#: Darkness added on a foggy night.
FOG_DARKNESS = 0.25
#: The light a covered lens lets through (the night camera's exposure and gain unchanged): the
#: frames are the sensor's noise on a black scene.
COVERED_TRANSMISSION = 0.002
#: Nights (inclusive) among which the season's events fall, drawn from the seed.
LANTERN_NIGHTS = (11, 15)
PLAYHOUSE_NIGHTS = (6, 10)
REMOVAL_NIGHTS = (16, 22)
AWAY_NIGHTS = (20, 26)
AUTUMN_NIGHTS = (4, 9)
#: The lawn covered by leaves MAX_LEAF_COVER at most (the last night of the leaf fall), a share
#: LEAVES_LEFT_BY_MOWING of them left by a mowing.
MAX_LEAF_COVER = 0.6
LEAF_FALL_NIGHTS = 40
LEAVES_LEFT_BY_MOWING = 0.25
#: Seeds of the drives' generators: night k of a season drives ``plan_night_drives`` night
#: SEASON_DRIVES + k (apart from the named nights' 0..4).
SEASON_DRIVES = 100
#: The other garden of an ``other_garden`` night: the world built from seed + this.
OTHER_GARDEN_SEED = 1000
#: Objects of the world a season takes away: world -> (name, footprint box x0, y0, x1, y1).
_REMOVED = {"garden": ("bench", (-1.46, 1.5, -0.85, 3.3)), "large_garden": ("compost box", (-1.6, 8.9, -0.5, 10.3))}
_LEAF_COLOURS = np.array([[0.30, 0.16, 0.05], [0.45, 0.33, 0.08], [0.38, 0.11, 0.05], [0.22, 0.14, 0.07]], np.float32)


@dataclass(frozen=True)
class SeasonNight:
    """One night of a season (:func:`plan_season`); what ``dataset.json`` records of it.

    Attributes:
        night: its number, 1..N.
        moon_phase: fraction of the lunar cycle (0 new, 0.5 full).
        moon: the moon's light on the scene, 0..1 of a full moon overhead a clear sky
            (:data:`~nightloc.synth.lighting.MOON_IRRADIANCE`): the lit fraction, 0 while it is
            down, dimmed by clouds.
        moon_direction: unit vector ``(x, y, z)`` towards the moon, or None while it is down.
        clouds: cloud cover, 0..1.
        rain: it rained tonight (overcast, the ground wet).
        wet: the ground is wet (rain tonight or last night).
        extra_darkness: added to the dataset's darkness (fog).
        lanterns: the garden lanterns stand (from the night they were put up).
        house_lamps: the house's lamps and lit window are on (off while the family is away).
        grass_cm: the grass height.
        mowed_night: the night of the last mowing (0: the day map's, before the season).
        stripes_along: ``"x"`` or ``"y"``, the direction the last mowing drove.
        leaf_cover: the share of the ground covered by fallen leaves.
        furniture_layout: which placement of the chairs and the table (a new one when moved).
        wheelbarrow: the wheelbarrow is out.
        playhouse: the playhouse stands.
        removed: the world's object taken away, if gone by tonight ("" while it stands).
        test_drive: tonight there is a test drive on the world's other path.
        bad: "" or one of :data:`BAD_NIGHTS`.
    """

    night: int
    moon_phase: float
    moon: float
    moon_direction: tuple[float, float, float] | None
    clouds: float
    rain: bool
    wet: bool
    extra_darkness: float
    lanterns: bool
    house_lamps: bool
    grass_cm: float
    mowed_night: int
    stripes_along: str
    leaf_cover: float
    furniture_layout: int
    wheelbarrow: bool
    playhouse: bool
    removed: str
    test_drive: bool
    bad: str = ""

    @property
    def stripe_contrast(self) -> float:
        """The mowing stripes' brightness contrast tonight (``STRIPE_CONTRAST`` right after mowing)."""
        return STRIPE_CONTRAST * math.exp(-(self.night - self.mowed_night) / STRIPE_FADE_NIGHTS)

    def describe(self) -> dict:
        """The night's conditions for ``dataset.json``."""
        record = asdict(self)
        record["moon_direction"] = None if self.moon_direction is None else [round(v, 6) for v in self.moon_direction]
        for key in ("moon_phase", "moon", "clouds", "grass_cm", "leaf_cover"):
            record[key] = round(float(record[key]), 4)
        record["stripe_contrast"] = round(self.stripe_contrast, 4)
        return record


@dataclass(frozen=True)
class _Events:
    """The season's events, drawn once from the seed (:func:`plan_season`)."""

    moon_phase0: float
    first_mowing: int
    lanterns: int
    playhouse: int
    removal: int
    away: int
    autumn: int


def _world_id(world: str) -> int:
    return ALL_WORLDS.index(world)


def _events(world: str, seed: int) -> _Events:
    rng = np.random.default_rng([int(seed), 30, _world_id(world)])

    def within(window: tuple[int, int]) -> int:
        return int(rng.integers(window[0], window[1] + 1))

    phase0 = float(rng.uniform(0.0, 1.0))
    first_mowing = within((1, MOWING_INTERVAL))
    lanterns, playhouse, removal = within(LANTERN_NIGHTS), within(PLAYHOUSE_NIGHTS), within(REMOVAL_NIGHTS)
    return _Events(phase0, first_mowing, lanterns, playhouse, removal, within(AWAY_NIGHTS), within(AUTUMN_NIGHTS))


def parse_bad_nights(spec: str | Mapping[int, str] | None, nights: int) -> dict[int, str]:
    """``{night: kind}`` from ``"10:covered,17:kidnapped"`` (or a mapping); ValueError naming the
    problem for an unknown kind, a night outside 1..``nights`` or a malformed item."""
    if spec is None:
        return {}
    if isinstance(spec, Mapping):
        items = [(str(k), str(v)) for k, v in spec.items()]
    else:
        items = []
        for part in (p.strip() for p in spec.split(",") if p.strip()):
            night, sep, kind = part.partition(":")
            if not sep:
                raise ValueError(f"bad nights are NIGHT:KIND items, e.g. 10:covered; got {part!r}")
            items.append((night.strip(), kind.strip()))
    out: dict[int, str] = {}
    for night, kind in items:
        if kind not in BAD_NIGHTS:
            raise ValueError(f"unknown bad night {kind!r}; choose from {', '.join(BAD_NIGHTS)}")
        if not night.isdigit() or not 1 <= int(night) <= nights:
            raise ValueError(f"a bad night's number must be in 1..{nights} (the season's nights), got {night!r}")
        if int(night) in out:
            raise ValueError(f"night {night} is given two bad kinds")
        out[int(night)] = kind
    return out


def plan_season(
    world: str, nights: int, seed: int = 0, *, test_every: int = 3, bad: Mapping[int, str] | str | None = None
) -> tuple[SeasonNight, ...]:
    """The ``nights`` nights of a season of ``world`` (:data:`SEASON_WORLDS`), drawn from ``seed``
    (see the module docstring); every ``test_every``-th night has a test drive (not a bad night's);
    ``bad``: ``{night: kind}`` or ``"NIGHT:KIND,..."`` (:func:`parse_bad_nights`)."""
    if world not in SEASON_WORLDS:
        raise ValueError(f"a season is drawn for {', '.join(SEASON_WORLDS)} (a lawn that grows), not {world!r}")
    if isinstance(nights, bool) or not isinstance(nights, (int, np.integer)) or not 1 <= nights <= 999:
        raise ValueError(f"a season has 1..999 nights, got {nights!r}")
    if isinstance(test_every, bool) or not isinstance(test_every, (int, np.integer)) or test_every < 1:
        raise ValueError(f"test_every must be an int >= 1 (a test drive every that many nights), got {test_every!r}")
    bad_nights = parse_bad_nights(bad, int(nights))
    events = _events(world, seed)
    out: list[SeasonNight] = []
    rained = False
    furniture = 0
    for k in range(1, int(nights) + 1):
        rng = np.random.default_rng([int(seed), 31, _world_id(world), k])
        rain = bool(rng.uniform() < 0.15)
        clouds = 1.0 if rain else float(rng.beta(0.6, 1.0))
        fog = bool(rng.uniform() < 0.08)
        furniture += int(rng.uniform() < 0.2)
        wheelbarrow = bool(rng.uniform() < 0.3)
        mowings = list(range(events.first_mowing, k + 1, MOWING_INTERVAL))
        mowed = mowings[-1] if mowings else 0
        phase = (events.moon_phase0 + k / SYNODIC_MONTH) % 1.0
        moon, direction = _moon(phase, clouds)
        leaf_cover = _leaf_cover(k, events.autumn, mowings)
        out.append(
            SeasonNight(
                night=k,
                moon_phase=phase,
                moon=moon,
                moon_direction=direction,
                clouds=clouds,
                rain=rain,
                wet=rain or rained,
                extra_darkness=(FOG_DARKNESS if fog else 0.0),
                lanterns=k >= events.lanterns,
                house_lamps=not events.away <= k < events.away + 3,
                grass_cm=MOWN_CM + GROWTH_CM_PER_NIGHT * (k - mowed),
                mowed_night=mowed,
                stripes_along="y" if len(mowings) % 2 else "x",
                leaf_cover=leaf_cover,
                furniture_layout=furniture,
                wheelbarrow=wheelbarrow,
                playhouse=k >= events.playhouse,
                removed=_REMOVED[world][0] if k >= events.removal else "",
                test_drive=k % test_every == 0 and k not in bad_nights,
                bad=bad_nights.get(k, ""),
            )
        )
        rained = rain
    return tuple(out)


def _moon(phase: float, clouds: float) -> tuple[float, tuple[float, float, float] | None]:
    """The moon's light and direction at the robot's hour: up from phase 0.1 to 0.8, from the
    west (azimuth pi) through the south to the east, 10-55 degrees high."""
    if not 0.1 <= phase <= 0.8:
        return 0.0, None
    t = (phase - 0.1) / 0.7
    azimuth = math.pi + math.pi * t
    elevation = math.radians(10.0 + 45.0 * math.sin(math.pi * t))
    lit = 0.5 * (1.0 - math.cos(2.0 * math.pi * phase))
    direction = (
        math.cos(elevation) * math.cos(azimuth),
        math.cos(elevation) * math.sin(azimuth),
        math.sin(elevation),
    )
    return lit * (1.0 - 0.9 * clouds), direction


def _leaf_cover(night: int, autumn: int, mowings: list[int]) -> float:
    """The share of the ground under leaves: each night of the fall adds an equal share; a mowing
    leaves LEAVES_LEFT_BY_MOWING of what lay before it."""
    cover = 0.0
    step = MAX_LEAF_COVER / LEAF_FALL_NIGHTS
    for k in range(autumn, night + 1):
        if k in mowings:
            cover *= LEAVES_LEFT_BY_MOWING
        if k < autumn + LEAF_FALL_NIGHTS:
            cover += step
    return cover


def season_traverse_names(night: SeasonNight) -> tuple[str, ...]:
    """The night's traverse folders: ``season_NNN`` (the re-drive of the day path) and, on a
    test night, ``season_NNN_query`` (the other path)."""
    name = f"season_{night.night:03d}"
    return (name, f"{name}_query") if night.test_drive else (name,)


def season_drives(world: str, seed: int, night: SeasonNight) -> list[TraversePlan]:
    """The night's drives, named :func:`season_traverse_names`: the re-drive of the day path
    (``plan_night_drives`` night ``SEASON_DRIVES + night``; a ``kidnapped`` night carried at
    half-time to the frame a third of the drive further on) and, on a test night, the other path."""
    redrive, query = plan_night_drives(world, seed, SEASON_DRIVES + night.night)
    names = season_traverse_names(night)
    redrive = replace(redrive, name=names[0])
    if night.bad == "kidnapped":
        n = len(redrive.positions)
        half, landing = n // 2, n // 2 + n // 3
        keep = np.r_[0:half, landing:n]
        redrive = replace(redrive, positions=redrive.positions[keep], headings=redrive.headings[keep], carried=(half,))
    return [redrive, replace(query, name=names[1])] if night.test_drive else [redrive]


def season_world(world: World, night: SeasonNight, seed: int) -> World:
    """``world`` (the day map's, :func:`~nightloc.synth.world.build_world`) on ``night``: its lamps,
    lawn, leaves, wet ground, furniture and objects (the module docstring); a new world object.
    ``seed`` draws the lanterns' and the furniture's places and the leaves."""
    off = set() if night.house_lamps else {"porch_lamp", "house_window"}
    lit = switch_lamps(world, off, _lantern_seed(seed) if night.lanterns else None)
    objects = [o for o in lit.objects if not (night.removed and _inside(o, _REMOVED[world.name][1]))]
    objects += _movables(lit, night, seed)
    return replace(lit, objects=objects, ground=_ground(world, night, seed))


def _lantern_seed(seed: int) -> int:
    return int(seed) * 1000 + 7


def _inside(solid: Solid, area: tuple[float, float, float, float]) -> bool:
    """Whether the solid's footprint lies within the box ``area`` (x0, y0, x1, y1)."""
    points = solid.footprint_polygon() if isinstance(solid, Cylinder) else solid.footprint
    x0, y0, x1, y1 = area
    return bool(np.all((points[:, 0] >= x0) & (points[:, 0] <= x1) & (points[:, 1] >= y0) & (points[:, 1] <= y1)))


def _ground(world: World, night: SeasonNight, seed: int) -> GroundMap:
    """The world's albedo map on ``night``: the lawn regrown and mowed, leaves, wet."""
    ground = world.ground
    values = ground.values.copy()
    if ground.lawn is not None and ground.stripes is not None:
        rows, cols = ground.lawn.shape
        xs = ground.x0 + (np.arange(cols) + 0.5) / ground.pixels_per_metre
        ys = ground.y0 + (np.arange(rows) + 0.5) / ground.pixels_per_metre
        across = ys[:, None] if night.stripes_along == "x" else xs[None, :]
        origin = ground.y0 if night.stripes_along == "x" else ground.x0
        band = np.floor((across - origin) / STRIPE_WIDTH_M) % 2 == 0
        stripes = np.where(band, 1.0 + night.stripe_contrast, 1.0 - night.stripe_contrast)
        tone = max(0.75, 1.0 - 0.03 * (night.grass_cm - MOWN_CM))  # taller grass: darker
        factor = np.where(ground.lawn, tone * stripes / ground.stripes, 1.0).astype(np.float32)
        values *= factor[..., None]
    if night.leaf_cover > 0:
        rng = np.random.default_rng([int(seed), 32, _world_id(world.name), night.night])
        cells = values.shape[0] * values.shape[1]
        count = int(round(night.leaf_cover * cells))
        flat = values.reshape(cells, 3)
        picked = rng.choice(cells, size=count, replace=False)
        flat[picked] = _LEAF_COLOURS[rng.integers(0, len(_LEAF_COLOURS), count)] * rng.uniform(0.7, 1.2, (count, 1))
    if night.wet:
        values *= np.float32(WET_ALBEDO)
    return replace(ground, values=np.ascontiguousarray(values, dtype=np.float32))


def _movables(world: World, night: SeasonNight, seed: int) -> list[Solid]:
    """The chairs, the table, the wheelbarrow and the playhouse where they stand tonight."""
    pieces: list[tuple[str, float, int]] = [("chair", 0.35, night.furniture_layout)] * 2
    pieces.append(("table", 0.5, night.furniture_layout))
    if night.wheelbarrow:
        pieces.append(("wheelbarrow", 0.65, 10_000 + night.night))
    if night.playhouse:
        pieces.append(("playhouse", 0.8, 20_000))
    taken: list[tuple[float, float, float]] = []
    out: list[Solid] = []
    for k, (kind, reach, layout) in enumerate(pieces):
        rng = np.random.default_rng([int(seed), 33, _world_id(world.name), layout, k])
        x, y, facing = _free_spot(world, reach, taken, rng)
        taken.append((x, y, reach))
        out.extend(_piece(kind, x, y, facing))
    return out


def _free_spot(
    world: World, reach: float, taken: list[tuple[float, float, float]], rng: np.random.Generator
) -> tuple[float, float, float]:
    """A place ``(x, y, facing)`` ``reach - 0.35`` (at least 0.1) to 1.35 m outside the mapped area
    (the drives keep 0.5 m inside it) where nothing of the world below 2 m (a fence, a shrub) nor
    a piece already placed stands within ``reach`` metres."""
    x0, y0, x1, y1 = world.mapped_area
    geometry = world.geometry
    low = geometry.bottom < 2.0
    for _ in range(4000):
        side = int(rng.integers(0, 4))
        along, out = rng.uniform(0.0, 1.0), rng.uniform(max(0.1, reach - 0.35), 1.35)
        x, y = (
            (x0 + along * (x1 - x0), y0 - out),
            (x1 + out, y0 + along * (y1 - y0)),
            (x0 + along * (x1 - x0), y1 + out),
            (x0 - out, y0 + along * (y1 - y0)),
        )[side]
        if any(math.hypot(x - px, y - py) < reach + pr for px, py, pr in taken):
            continue
        probes = [(x + dx * reach, y + dy * reach) for dx, dy in ((0, 0), (1, 0), (-1, 0), (0, 1), (0, -1))]
        if not any(np.any(geometry.inside_footprint(px, py) & low) for px, py in probes):
            return float(x), float(y), float(rng.uniform(-math.pi, math.pi))
    raise ValueError(f"no room for the season's furniture round the mapped area of {world.name!r}")


def _piece(kind: str, x: float, y: float, facing: float) -> list[Solid]:
    """The solids of one piece of furniture at ``(x, y)`` turned to ``facing`` (radians)."""
    c, s = math.cos(facing), math.sin(facing)

    def turned(width: float, depth: float, dx: float = 0.0, dy: float = 0.0) -> np.ndarray:
        corners = np.array([[-width, -depth], [width, -depth], [width, depth], [-width, depth]]) / 2 + (dx, dy)
        return corners @ np.array([[c, s], [-s, c]]) + (x, y)

    if kind == "chair":
        return [Prism(turned(0.45, 0.45), 0.0, 0.45, "metal"), Prism(turned(0.45, 0.06, 0.0, 0.2), 0.45, 0.9, "metal")]
    if kind == "table":
        return [Cylinder((x, y), 0.06, 0.0, 0.68, "metal"), Cylinder((x, y), 0.45, 0.68, 0.74, "lamp")]
    if kind == "wheelbarrow":
        return [Prism(turned(0.6, 1.1), 0.2, 0.55, "shed")]
    return [Prism(turned(1.2, 1.0), 0.0, 1.45, "shed"), Prism(turned(1.35, 1.15), 1.45, 1.55, "metal")]


def other_garden(world: str, seed: int) -> World:
    """Another garden for an ``other_garden`` night: ``world`` built from ``seed +
    OTHER_GARDEN_SEED`` (other textures, another sun) and mirrored about its mapped area's middle
    (x -> x0 + x1 - x: the house, the shed and the trees on the other side, every view a mirror
    image no turn of this garden's matches); the same mapped area, so the robot's usual drive fits
    it."""
    base = build_world(world, int(seed) + OTHER_GARDEN_SEED)
    x0, _, x1, _ = base.mapped_area
    cx = x0 + x1  # x -> cx - x mirrors about the middle

    def mirrored(solid: Solid) -> Solid:
        if isinstance(solid, Cylinder):
            return replace(solid, center=(cx - solid.center[0], solid.center[1]))
        footprint = solid.footprint[::-1].copy()  # a mirror turns the vertices clockwise: reverse them
        footprint[:, 0] = cx - footprint[:, 0]
        return replace(solid, footprint=footprint)

    g = base.ground
    cols = g.values.shape[1]
    ground = GroundMap(
        np.ascontiguousarray(g.values[:, ::-1]),
        cx - (g.x0 + cols / g.pixels_per_metre),
        g.y0,
        g.pixels_per_metre,
        None if g.lawn is None else np.ascontiguousarray(g.lawn[:, ::-1]),
        None if g.stripes is None else np.ascontiguousarray(g.stripes[:, ::-1]),
    )
    lights = {
        name: replace(light, position=(cx - light.position[0], light.position[1], light.position[2]))
        for name, light in base.lights.items()
    }
    return replace(base, objects=[mirrored(o) for o in base.objects], ground=ground, lights=lights)
