"""nightloc.synth: a small deterministic day/night panoramic world, the embedded default dataset.

The paper's garden and living-room datasets cannot be downloaded here, so nightloc renders
look-alikes: a 7 x 5 m garden lawn (fences, shrubs, a shed, a house, trees near and far, sky) and
a 6 x 3 m living-room floor (walls with pictures and windows, furniture, lamps), as 360-degree
cylindrical panoramas taken 0.3 m above the ground, by day (sun, shadows, sun patches through
the windows, house lights) and at night (dark sky, lamps with inverse-square fall-off, a dark,
noisy exposure whose ``darkness`` can be swept). The traverses mirror the paper's Table I.

Quick start::

    from nightloc.synth import make_dataset, default_dataset
    folders = make_dataset("garden", "data/garden", seed=0)     # {"day_reference": Path, ...}
    paths = default_dataset()      # both worlds, generated once into ~/.cache/nightloc
    nights = make_dataset("garden", "data/nights", nights="lamps,moon_only")  # other nights too

    from nightloc.synth import SynthScene  # single frames
    scene = SynthScene("living_room", seed=0, darkness=1.0)
    image = scene.frame("night", x=2.0, y=1.5, heading=0.3)     # (96, 192, 3) uint8 BGR

Modules: :mod:`~nightloc.synth.geometry` (prisms, ray intersection), :mod:`~nightloc.synth.textures`
(procedural textures), :mod:`~nightloc.synth.world` (the two worlds), :mod:`~nightloc.synth.lighting`
(day/night light, sky, cast shadows), :mod:`~nightloc.synth.sensor` (exposure, noise, tone curve),
:mod:`~nightloc.synth.render` (ray casting, panorama convention), :mod:`~nightloc.synth.paths`
(Table I traverses), :mod:`~nightloc.synth.dataset` (writing traverses, the cached default),
:mod:`~nightloc.synth.creek` (the paper's moonless 500 m creek path, for route mode),
:mod:`~nightloc.synth.nights` (nights that differ: moved lamps, the moon, lamps off, darker),
:mod:`~nightloc.synth.season` (a season of nights: light, lawn, leaves, furniture, bad nights).
"""

from __future__ import annotations

from .dataset import (
    DEFAULT_DARKNESS,
    DEFAULT_SEED,
    GENERATOR_VERSION,
    SynthScene,
    default_cache_dir,
    default_dataset,
    make_dataset,
)
from .nights import NIGHT_NAMES, NIGHTS, NightCondition
from .paths import TRAVERSE_NAMES, TraversePlan, plan_night_drives, plan_traverses
from .render import Camera, cast_rays, column_azimuths, render_panorama, render_radiance, row_elevations
from .world import WORLD_NAMES, World, build_world

__all__ = [
    "DEFAULT_DARKNESS",
    "DEFAULT_SEED",
    "GENERATOR_VERSION",
    "NIGHTS",
    "NIGHT_NAMES",
    "TRAVERSE_NAMES",
    "WORLD_NAMES",
    "Camera",
    "NightCondition",
    "SynthScene",
    "TraversePlan",
    "World",
    "build_world",
    "cast_rays",
    "column_azimuths",
    "default_cache_dir",
    "default_dataset",
    "make_dataset",
    "plan_night_drives",
    "plan_traverses",
    "render_panorama",
    "render_radiance",
    "row_elevations",
]
