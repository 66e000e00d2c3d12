"""Nights that differ: the named night conditions a synthetic dataset can hold beside its usual one.

A robot that runs every night never sees the same night twice: a lamp is moved or left off, the
moon rises, clouds darken the sky. Each :class:`NightCondition` changes one thing of the world's
usual night (``lamps``):

============  ===============================================================================
name          the night
============  ===============================================================================
lamps         the usual night: the world's night lamps, the dataset's darkness
lamps_moved   another lamp layout: the porch or room lamps off, others placed elsewhere (from a seed)
moonlit       the usual lamps under a full moon (moon shadows, a brighter sky)
moon_only     every lamp of the house off: only the full moon and the sky light the scene
darker        the usual lamps at a darker exposure (darkness + 0.3: a quarter of the photons)
============  ===============================================================================

The night camera is the same on every night: its exposure is metered once on the usual night
(:class:`~nightloc.synth.dataset.SynthScene`), as a robot's night mode sets it, so a darker night
collects fewer photo-electrons and its frames are darker and noisier (:mod:`nightloc.synth.sensor`);
only ``darker`` changes the exposure itself.

:func:`lamp_layout` places the ``lamps_moved`` lamps: outdoors the porch lamp is off (the street
lamp and the house's lit window stay on) and garden lanterns stand on posts in a band
just outside the mapped area; indoors every lamp is off and floor lamps stand where the floor is
free between the mapped area and the walls. :func:`moon_direction` draws the moon's place in the
sky (indoors in the south, so it shines through the windows).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace

import numpy as np

from .geometry import Cylinder, Solid
from .world import ALL_WORLDS, LightSource, World

__all__ = [
    "NIGHTS",
    "NIGHT_NAMES",
    "USUAL_NIGHT",
    "NightCondition",
    "lamp_layout",
    "moon_direction",
    "night_traverse_name",
    "parse_nights",
    "switch_lamps",
]


@dataclass(frozen=True)
class NightCondition:
    """One kind of night.

    Attributes:
        name: its name, e.g. ``"moon_only"`` (the suffix of its traverse folders).
        description: one line for ``--help`` and ``dataset.json``.
        lamps: ``"usual"`` (the world's night lamps), ``"moved"`` (:func:`lamp_layout`) or ``"off"``
            (every lamp of the house off; a street lamp too).
        moon: the moon's light, 0 none, 1 a full moon
            (:data:`~nightloc.synth.lighting.MOON_IRRADIANCE`).
        extra_darkness: added to the dataset's darkness (:mod:`nightloc.synth.sensor`).
    """

    name: str
    description: str
    lamps: str = "usual"
    moon: float = 0.0
    extra_darkness: float = 0.0


#: The usual night: the traverses of the paper's Table I.
USUAL_NIGHT = "lamps"
#: Every night condition by name.
NIGHTS: dict[str, NightCondition] = {
    night.name: night
    for night in (
        NightCondition(USUAL_NIGHT, "the world's usual night lamps"),
        NightCondition(
            "lamps_moved", "another lamp layout: the porch or room lamps off, others elsewhere", lamps="moved"
        ),
        NightCondition("moonlit", "the usual lamps under a full moon", moon=1.0),
        NightCondition(
            "moon_only", "every lamp off: only the full moon and the sky light the scene", lamps="off", moon=1.0
        ),
        NightCondition("darker", "the usual lamps at darkness + 0.3: a quarter of the photons", extra_darkness=0.3),
    )
}
NIGHT_NAMES: tuple[str, ...] = tuple(NIGHTS)


def parse_nights(nights: str | Sequence[str]) -> tuple[str, ...]:
    """The night names of ``"lamps,moon_only"`` (or a sequence of names; ``"all"`` = every
    night), in :data:`NIGHT_NAMES` order without repeats; ValueError naming the choices for an
    unknown or empty one."""
    names = [n.strip() for n in nights.split(",")] if isinstance(nights, str) else [str(n).strip() for n in nights]
    if "all" in names:
        return NIGHT_NAMES
    unknown = [n for n in names if n not in NIGHTS]
    if unknown or not names:
        what = f"unknown night {unknown[0]!r}" if unknown else "no night given"
        raise ValueError(f"{what}; choose from {', '.join(NIGHT_NAMES)} (comma-separated) or all")
    return tuple(n for n in NIGHT_NAMES if n in names)


def night_traverse_name(traverse: str, night: str) -> str:
    """The folder of ``traverse`` (``"night_reference"`` or ``"night_query"``) on ``night``: the
    usual night keeps Table I's name, another gets its name appended (``night_query_moon_only``)."""
    return traverse if night == USUAL_NIGHT else f"{traverse}_{night}"


#: The lamps switched where the robot lives: off on the ``lamps_moved`` night (the street lamp and the
#: house's lit window stay on; every lamp is off on ``moon_only``).
_HOUSE_LAMPS = frozenset({"porch_lamp", "floor_lamp", "table_lamp", "oven"})


@dataclass(frozen=True)
class _LampStyle:
    """A lamp on a post: post height, glowing head's height range and the light's height (m),
    RGB power (irradiance 1 m away, :class:`~nightloc.synth.world.LightSource`), glow gain."""

    post: float
    head: tuple[float, float]
    light_z: float
    power: tuple[float, float, float]
    glow: float


#: A garden lantern: a 0.8 m post, a glowing head, about 250 lumen (0.15 units at 1 m).
_LANTERN = _LampStyle(0.8, (0.8, 1.0), 0.9, (0.15, 0.13, 0.09), 40.0)
#: A floor lamp like the living room's own.
_FLOOR_LAMP = _LampStyle(1.4, (1.4, 1.72), 1.55, (0.30, 0.22, 0.12), 25.0)


def lamp_layout(world: World, layout_seed: int, lamps: str = "moved") -> World:
    """``world`` with the lamps of another night: ``lamps`` ``"usual"`` (``world`` itself),
    ``"off"`` (every night lamp off) or ``"moved"``.

    ``"moved"``: the porch lamp or the room's lamps off and new ones, drawn from ``layout_seed``: outdoors one
    garden lantern (a 0.8 m post with a glowing head, light at 0.9 m, about 250 lumen) per 8 m of
    the mapped area's perimeter, in a band 0.6-1.1 m outside it; indoors two floor lamps (light at 1.55 m)
    0.25-0.75 m outside it, towards the walls. A place is used only where no object of the world
    stands within 0.25 m. The returned world is a new object (its geometry includes the lamps).
    """
    if lamps == "usual":
        return world
    if lamps not in ("moved", "off"):
        raise ValueError(f"lamps must be 'usual', 'moved' or 'off', got {lamps!r}")
    off = set(world.lights) if lamps == "off" else _HOUSE_LAMPS
    return switch_lamps(world, off, layout_seed if lamps == "moved" else None)


def switch_lamps(world: World, off: Collection[str], lantern_seed: int | None = None) -> World:
    """``world`` with its lamps named in ``off`` switched off at night and, given ``lantern_seed``, the
    lamps of :func:`lamp_layout`'s ``"moved"`` night placed from that seed (garden lanterns
    outdoors, floor lamps indoors). A new world object."""
    switched = {
        name: replace(light, conditions=tuple(c for c in light.conditions if c != "night")) if name in off else light
        for name, light in world.lights.items()
    }
    objects: list[Solid] = list(world.objects)
    if lantern_seed is not None:
        style = _FLOOR_LAMP if world.indoor else _LANTERN
        post = "metal"
        head = "shade" if "shade" in world.materials else "lamp"
        for k, (x, y) in enumerate(_lamp_places(world, lantern_seed)):
            name = f"moved_lamp_{k}"
            objects.append(Cylinder((x, y), 0.03, 0.0, style.post, post))
            objects.append(Cylinder((x, y), 0.12, *style.head, head, emission=name))
            switched[name] = LightSource((x, y, style.light_z), style.power, ("night",), glow=style.glow)
    return replace(world, objects=objects, lights=switched)


def _lamp_places(world: World, layout_seed: int) -> list[tuple[float, float]]:
    """Where the moved lamps stand: ``(x, y)`` metres, drawn from ``layout_seed``."""
    x0, y0, x1, y1 = world.mapped_area
    inner, outer = (0.25, 0.75) if world.indoor else (0.6, 1.1)
    count = 2 if world.indoor else max(1, int(round(2 * ((x1 - x0) + (y1 - y0)) / 8.0)))
    rng = np.random.default_rng([int(layout_seed), 11, ALL_WORLDS.index(world.name) if world.name in ALL_WORLDS else 9])
    lengths = np.array([x1 - x0, y1 - y0, x1 - x0, y1 - y0])  # south, east, north, west sides
    geometry = world.geometry
    places: list[tuple[float, float]] = []
    for _ in range(2000):
        if len(places) == count:
            break
        side = rng.choice(4, p=lengths / lengths.sum())
        along, out = rng.uniform(0.0, 1.0), rng.uniform(inner, outer)
        x, y = (
            (x0 + along * (x1 - x0), y0 - out),
            (x1 + out, y0 + along * (y1 - y0)),
            (x0 + along * (x1 - x0), y1 + out),
            (x0 - out, y0 + along * (y1 - y0)),
        )[side]
        if any(np.hypot(x - px, y - py) < 2.0 for px, py in places):
            continue  # lamps spread out
        near = [
            geometry.inside_footprint(x + dx, y + dy)
            for dx, dy in ((0, 0), (0.25, 0), (-0.25, 0), (0, 0.25), (0, -0.25))
        ]
        if not np.any(np.any(near, axis=0) & (geometry.bottom < 1.8)):
            places.append((float(x), float(y)))
    if len(places) < count:
        raise ValueError(f"no room for {count} lamps round the mapped area of {world.name!r}")
    return places


def moon_direction(world: World, seed: int) -> np.ndarray:
    """Unit vector ``(x, y, z)`` towards the moon of ``seed``'s nights: outdoors 30-55 degrees high
    at any azimuth; indoors 25-38 degrees high in the south (it shines through the south windows)."""
    rng = np.random.default_rng([int(seed), 12, ALL_WORLDS.index(world.name) if world.name in ALL_WORLDS else 9])
    if world.indoor:
        azimuth, elevation = np.radians(rng.uniform(-125.0, -55.0)), np.radians(rng.uniform(25.0, 38.0))
    else:
        azimuth, elevation = rng.uniform(-np.pi, np.pi), np.radians(rng.uniform(30.0, 55.0))
    return np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])


def lamps_on(world: World) -> list[dict]:
    """The lamps on at night in ``world``: name, position (m) and RGB power, for ``dataset.json``."""
    return [
        {"name": name, "position": [round(float(v), 4) for v in light.position], "power": list(light.power)}
        for name, light in sorted(world.lights.items())
        if "night" in light.conditions
    ]
