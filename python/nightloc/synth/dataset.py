"""Writing the synthetic traverses to disk, and the cached default dataset.

``make_dataset("garden", out_dir)`` renders every traverse of the world (see
:mod:`nightloc.synth.paths`) and writes each with :func:`nightloc.save_traverse` as
``out_dir/<traverse>/images/000000.png ... + poses.csv`` (header ``image,x,y,heading,timestamp``)
``+ odometry.csv`` (``image,forward,left,turn,timestamp``), plus ``out_dir/dataset.json``
describing the world (mapped area, lighting, camera, the drive's timing, generator version). The
times are the plan's (:meth:`~nightloc.synth.paths.TraversePlan.timestamps`: a documented drive
speed and camera rate).

Other nights (``nights=``, :mod:`nightloc.synth.nights`): each night's two drives
(:func:`~nightloc.synth.paths.plan_night_drives`) go to ``out_dir/night_reference_<night>`` and
``out_dir/night_query_<night>`` (the usual night ``lamps`` keeps Table I's names), and
``dataset.json`` records every night's condition under ``nights``.

Determinism: every frame's sensor noise comes from its own generator seeded with
``(seed, world, traverse, frame)``, so the same seed gives byte-identical images whatever the
number of threads.
"""

from __future__ import annotations

import copy
import json
import os
import shutil
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._validate import thread_count
from ..io.atomic import locked_target, make_folder, output_set, replace_folder, staging_folder, write_text
from ..io.files import open_regular
from ..io.traverse import save_traverse
from ..motion.odometry import RobotMotion
from ..motion.wheel_noise import WheelNoise
from ..progress import progress
from .lighting import MOON_IRRADIANCE, Lighting, make_lighting, make_night_lighting
from .nights import (
    NIGHT_NAMES,
    NIGHTS,
    USUAL_NIGHT,
    lamp_layout,
    lamps_on,
    moon_direction,
    night_traverse_name,
    parse_nights,
)
from .paths import (
    CAMERA_RATE_HZ,
    DRIVE_SPEED_M_S,
    FIRST_FRAME_S,
    NIGHT_DRIVES,
    TRAVERSE_NAMES,
    TraversePlan,
    plan_night_drives,
    plan_traverses,
)
from .render import Camera, render_panorama, render_radiance
from .season import (
    COVERED_TRANSMISSION,
    SeasonNight,
    other_garden,
    plan_season,
    season_drives,
    season_traverse_names,
    season_world,
)
from .sensor import FULL_WELL, MAX_DARKNESS, READ_NOISE, Exposure, capture, metered_exposure
from .world import ALL_WORLDS, WORLD_NAMES, World, build_world

__all__ = [
    "DEFAULT_DARKNESS",
    "DEFAULT_SEED",
    "GENERATOR_VERSION",
    "SynthScene",
    "default_cache_dir",
    "default_dataset",
    "forward_view",
    "make_dataset",
]

#: Bumped whenever the generator's output changes; part of the cache folder's name.
GENERATOR_VERSION = "3"
DEFAULT_SEED = 0
#: Night darkness of the default data (see :mod:`nightloc.synth.sensor`).
DEFAULT_DARKNESS = 1.0
NIGHT_GAMMA = 1.8  # the night camera's tone curve lifts the shadows a little more than day's 2.2
DAY_GAMMA = 2.2
#: The wheel odometry every drive's ``odometry.csv`` holds (the defaults: a measured wheel base).
SYNTH_WHEEL_NOISE = WheelNoise()


class SynthScene:
    """A world with its day and night lighting and metered exposures, ready to render frames.

    Args:
        world: ``"garden"`` or ``"living_room"``.
        seed: textures, sun direction and sensor noise.
        darkness: night darkness (0 = night lighting exposed like day; 1 = 100x fewer photons).
        camera: panorama size and optics (default 192 x 96).
    """

    def __init__(
        self, world: str, seed: int = DEFAULT_SEED, darkness: float = DEFAULT_DARKNESS, camera: Camera | None = None
    ):
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be an int >= 0, got {seed!r}")
        self.seed = int(seed)
        self.darkness = float(darkness)
        self.camera = camera or Camera()
        self.world: World = build_world(world, self.seed)
        self.lighting: dict[str, Lighting] = {c: make_lighting(self.world, c, self.seed) for c in ("day", "night")}
        self.metered: dict[str, float] = {c: self._meter(c) for c in ("day", "night")}
        self.exposure: dict[str, Exposure] = {
            "day": metered_exposure(self.metered["day"], 0.0, DAY_GAMMA),
            "night": metered_exposure(self.metered["night"], self.darkness, NIGHT_GAMMA),
        }
        #: The night condition of the ``"night"`` lighting (:mod:`nightloc.synth.nights`).
        self.night_name = USUAL_NIGHT
        self.moon_direction: np.ndarray | None = None
        self._usual_night = (self.world, self.darkness)  # what every night() starts from

    def night(self, name: str) -> SynthScene:
        """This scene on the night ``name`` (:data:`~nightloc.synth.nights.NIGHTS`): the same world,
        day and night camera (its exposure metered on the usual night), with that night's lamps,
        moon and darkness (the scene's plus the night's ``extra_darkness``). The moon's direction
        and the moved lamps are drawn from the scene's seed."""
        if name not in NIGHTS:
            raise ValueError(f"unknown night {name!r}; choose from {', '.join(NIGHT_NAMES)}")
        condition = NIGHTS[name]
        usual_world, usual_darkness = self._usual_night
        darkness = usual_darkness + condition.extra_darkness
        if darkness > MAX_DARKNESS:
            raise ValueError(
                f"night {name!r} adds {condition.extra_darkness} to the darkness {usual_darkness}: at most "
                f"{MAX_DARKNESS:g} in all"
            )
        world = lamp_layout(usual_world, self.seed, condition.lamps)
        direction = moon_direction(world, self.seed) if condition.moon > 0 else None
        return self._lit_night(name, world, darkness, condition.moon, direction)

    def season_night(self, night: SeasonNight) -> SynthScene:
        """This scene on a night of a season (:func:`~nightloc.synth.season.plan_season`): the world's
        lamps, lawn, leaves, furniture and objects of that night
        (:func:`~nightloc.synth.season.season_world`; an ``other_garden`` night: another garden,
        :func:`~nightloc.synth.season.other_garden`), its moon and darkness; the same day and
        night camera."""
        usual_world, usual_darkness = self._usual_night
        if night.bad == "other_garden":
            world = other_garden(usual_world.name, self.seed)
        else:
            world = season_world(usual_world, night, self.seed)
        darkness = min(usual_darkness + night.extra_darkness, 3.0)
        direction = None if night.moon_direction is None else np.asarray(night.moon_direction)
        moon = night.moon if direction is not None else 0.0
        scene = self._lit_night(f"season night {night.night}", world, darkness, moon, direction)
        if night.bad == "covered":  # the lens covered: the same exposure, hardly any light
            exposure = scene.exposure["night"]
            scene.exposure["night"] = replace(
                exposure, electrons_per_unit=exposure.electrons_per_unit * COVERED_TRANSMISSION
            )
        return scene

    def _lit_night(
        self, name: str, world: World, darkness: float, moon: float, direction: np.ndarray | None
    ) -> SynthScene:
        """A copy of this scene whose night is ``world``'s (its lamps), the moon's and ``darkness``."""
        usual_world = self._usual_night[0]
        usual_power = sum(sum(light.power) for light in usual_world.lights.values() if "night" in light.conditions)
        power = sum(sum(light.power) for light in world.lights.values() if "night" in light.conditions)
        night = copy.copy(self)
        night.world = world
        night.darkness = darkness
        night.night_name = name
        night.moon_direction = direction
        night.lighting = {
            "day": self.lighting["day"],
            "night": make_night_lighting(
                world,
                self.seed,
                moon=moon,
                moon_direction=direction,
                lamp_bounce=power / usual_power if usual_power > 0 else 1.0,
            ),
        }
        night.exposure = {"day": self.exposure["day"], "night": self.night_exposure(darkness)}
        return night

    def describe_night(self) -> dict:
        """The ``dataset.json`` record of this scene's night: its condition, lamps, moon, darkness."""
        condition = NIGHTS[self.night_name]
        moon = None
        if self.moon_direction is not None:
            moon = {
                "level": condition.moon,
                "irradiance": condition.moon * MOON_IRRADIANCE,
                "direction": [round(float(v), 6) for v in self.moon_direction],
            }
        return {
            "description": condition.description,
            "lamps": condition.lamps,
            "lamp_layout_seed": self.seed if condition.lamps == "moved" else None,
            "lamps_on": lamps_on(self.world),
            "moon": moon,
            "darkness": self.darkness,
        }

    def night_exposure(self, darkness: float, full_well: float = FULL_WELL, read_noise: float = READ_NOISE) -> Exposure:
        """The night camera's exposure at ``darkness`` with a pixel of ``full_well`` electrons and
        ``read_noise`` electrons rms (:func:`~nightloc.synth.sensor.metered_exposure`)."""
        return metered_exposure(
            self.metered["night"], darkness, NIGHT_GAMMA, full_well=full_well, read_noise=read_noise
        )

    def _meter(self, condition: str) -> float:
        """Highlight-clipped mean radiance seen from the middle of the mapped area (heading 0)."""
        x0, y0, x1, y1 = self.world.mapped_area
        radiance = render_radiance(self.world, self.lighting[condition], (x0 + x1) / 2, (y0 + y1) / 2, 0.0, self.camera)
        return float(np.minimum(radiance, np.percentile(radiance, 98.0)).mean())

    def frame(
        self, condition: str, x: float, y: float, heading: float, rng: np.random.Generator | None = None
    ) -> np.ndarray:
        """One ``(height, width, 3)`` uint8 BGR panorama; ``rng`` None renders it noiseless."""
        return render_panorama(
            self.world, self.lighting[condition], self.exposure[condition], x, y, heading, self.camera, rng
        )

    def tilted_frame(
        self,
        condition: str,
        x: float,
        y: float,
        heading: float,
        pitch_deg: float,
        roll_deg: float,
        height: float | None = None,
        rng: np.random.Generator | None = None,
    ) -> np.ndarray:
        """:meth:`frame` from a tilted camera: pitched ``pitch_deg`` (nose up) and rolled ``roll_deg``
        (left side up), ``height`` metres above the ground (default the world's). A panorama's
        column at azimuth a (relative to the heading, counter-clockwise) then looks ``pitch cos a + roll sin a``
        degrees higher: rendered over a taller elevation range and each column resampled there
        (small tilts: the columns' slant across a pixel is left out)."""
        cam = self.camera
        margin = abs(pitch_deg) + abs(roll_deg) + 1.0
        rows_per_degree = cam.height / (cam.elevation_top_deg - cam.elevation_bottom_deg)
        extra = int(np.ceil(margin * rows_per_degree))
        tall = replace(
            cam,
            height=cam.height + 2 * extra,
            elevation_top_deg=cam.elevation_top_deg + extra / rows_per_degree,
            elevation_bottom_deg=cam.elevation_bottom_deg - extra / rows_per_degree,
        )
        radiance = render_radiance(self.world, self.lighting[condition], x, y, heading, tall, height)
        relative = -2.0 * np.pi * np.arange(cam.width) / cam.width  # column azimuth minus the heading
        lift = pitch_deg * np.cos(relative) + roll_deg * np.sin(relative)  # degrees, per column
        # row r of the tilted camera looks at the tall image's row r + extra - lift rows_per_degree
        source = np.arange(cam.height)[:, None] + extra - lift[None, :] * rows_per_degree
        r0 = np.clip(np.floor(source).astype(int), 0, tall.height - 2)
        frac = np.clip(source - r0, 0.0, 1.0)[..., None].astype(np.float32)
        columns = np.arange(cam.width)[None, :]
        out = (1 - frac) * radiance[r0, columns] + frac * radiance[r0 + 1, columns]
        return capture(out.astype(np.float32), self.exposure[condition], rng)

    def frame_rng(self, traverse: str, index: int) -> np.random.Generator:
        """The noise generator of frame ``index`` of ``traverse`` (independent of render order)."""
        world_id = ALL_WORLDS.index(self.world.name)
        traverse_id = sum(ord(c) * (i + 1) for i, c in enumerate(traverse))
        return np.random.default_rng([self.seed, 5, world_id, traverse_id, int(index)])

    def tilt_rng(self, traverse: str, index: int) -> np.random.Generator:
        """The generator of frame ``index``'s tilt and camera height (its own: the untilted frames do
        not change)."""
        world_id = ALL_WORLDS.index(self.world.name)
        traverse_id = sum(ord(c) * (i + 1) for i, c in enumerate(traverse))
        return np.random.default_rng([self.seed, 7, world_id, traverse_id, int(index)])

    def odometry_rng(self, traverse: str) -> np.random.Generator:
        """The generator of ``traverse``'s wheel-odometry noise (its own: the images do not depend on it)."""
        world_id = ALL_WORLDS.index(self.world.name)
        traverse_id = sum(ord(c) * (i + 1) for i, c in enumerate(traverse))
        return np.random.default_rng([self.seed, 6, world_id, traverse_id])

    def render_plan(
        self, plan: TraversePlan, threads: int | None = None, tilt_deg: float = 0.0, height_std: float = 0.0
    ) -> Iterator[np.ndarray]:
        """Renders the frames of ``plan`` in order (``threads`` at a time; default all cores).
        ``tilt_deg`` > 0: each frame's camera pitched and rolled by N(0, tilt_deg) degrees;
        ``height_std`` > 0: its height off by N(0, height_std) metres (a robot on a lawn); both
        from the frame's own seeded generator (:meth:`tilted_frame`)."""
        self.world.check_camera_positions(plan.positions)

        def one(index: int) -> np.ndarray:
            x, y = plan.positions[index]
            heading, rng = float(plan.headings[index]), self.frame_rng(plan.name, index)
            if tilt_deg <= 0 and height_std <= 0:
                return self.frame(plan.condition, float(x), float(y), heading, rng)
            pitch, roll, lift = self.tilt_rng(plan.name, index).normal(0.0, 1.0, 3) * (tilt_deg, tilt_deg, height_std)
            height = self.world.camera_height + float(np.clip(lift, -3 * height_std, 3 * height_std))
            return self.tilted_frame(
                plan.condition, float(x), float(y), heading, float(pitch), float(roll), height, rng
            )

        workers = thread_count(threads)
        if workers == 1:
            yield from (one(i) for i in range(len(plan.positions)))
            return
        with ThreadPoolExecutor(max_workers=workers) as pool:
            yield from pool.map(one, range(len(plan.positions)))

    def describe(self, plans: list[TraversePlan]) -> dict:
        """The dataset.json content: generator, world, lighting, camera and traverses."""
        day = self.lighting["day"]
        return {
            "generator": "nightloc.synth",
            "generator_version": GENERATOR_VERSION,
            "world": self.world.name,
            "seed": self.seed,
            "darkness": self.darkness,
            "mapped_area": {
                "x0": self.world.mapped_area[0],
                "y0": self.world.mapped_area[1],
                "x1": self.world.mapped_area[2],
                "y1": self.world.mapped_area[3],
            },
            "camera": {
                "width": self.camera.width,
                "height": self.camera.height,
                "height_above_ground_m": self.world.camera_height,
                "elevation_top_deg": self.camera.elevation_top_deg,
                "elevation_bottom_deg": self.camera.elevation_bottom_deg,
                "column_azimuth": "heading - 2*pi*column/width",
            },
            "odometry": {
                "model": "wheel",
                "scale_std": SYNTH_WHEEL_NOISE.scale_std,
                "distance_std": SYNTH_WHEEL_NOISE.distance_std,
                "turn_std_rad": SYNTH_WHEEL_NOISE.turn_std,
                "turn_bias_std_rad_per_step": SYNTH_WHEEL_NOISE.turn_bias_std,
            },
            "timing": {
                "drive_speed_m_s": DRIVE_SPEED_M_S,
                "camera_rate_hz": CAMERA_RATE_HZ,
                "first_frame_s": FIRST_FRAME_S,
            },
            "sun_direction": [round(float(v), 6) for v in day.sun_direction] if day.sun_direction is not None else None,
            "traverses": {p.name: {"condition": p.condition, "frames": int(len(p.positions))} for p in plans},
        }


def _write_json_atomic(path: Path, content: dict) -> None:
    write_text(path, json.dumps(content, indent=2) + "\n")


def _plan_drives(
    world: str,
    scene: SynthScene,
    pattern: str,
    night_names: Sequence[str] | None,
    schedule: Sequence[SeasonNight] | None,
    view: str,
) -> tuple[list, dict[str, SynthScene], dict[str, SynthScene], dict[str, SeasonNight]]:
    """The drives to render, in order (Table I's, or the day reference then each night's or each
    season night's drives; a forward camera's day reference four ways), the scene of each drive
    that is not ``scene``'s, the nights' scenes by name and the season night of each season drive."""
    plans = plan_traverses(world, scene.seed, pattern)
    scenes = {plan.name: scene for plan in plans}
    night_scenes: dict[str, SynthScene] = {}
    season_of: dict[str, SeasonNight] = {}  # a season's drives: their night (its scene made when rendered)
    if night_names is not None:
        plans, night_scenes = plans[:1], {name: scene.night(name) for name in night_names}
        for name in night_names:
            for drive in plan_night_drives(world, scene.seed, NIGHT_NAMES.index(name), pattern):
                plans.append(replace(drive, name=night_traverse_name(drive.name, name)))
                scenes[plans[-1].name] = night_scenes[name]
    if schedule is not None:
        plans = plans[:1]
        for night in schedule:
            for drive in season_drives(world, scene.seed, night):
                plans.append(drive)
                season_of[drive.name] = night
    if view == "forward":
        plans = [_four_ways(plan) if plan.name == "day_reference" else plan for plan in plans]
    return plans, scenes, night_scenes, season_of


def _describe_dataset(
    scene: SynthScene,
    plans: list,
    view: str,
    tilt_deg: float,
    height_std: float,
    pattern: str,
    schedule: Sequence[SeasonNight] | None,
    lamps: dict[int, list[dict]],
    test_every: int,
) -> dict:
    """``dataset.json``'s description: the scene's, the camera's motion, and a season's schedule."""
    description = scene.describe(plans)
    description.update(view=view, tilt_deg=float(tilt_deg), height_std_m=float(height_std))
    if pattern != "rows":
        description.update(pattern=pattern)
    if schedule is not None:
        description["season"] = {
            "nights": len(schedule),
            "test_every": test_every,
            "schedule": [
                {**n.describe(), "lamps_on": lamps[n.night], "traverses": list(season_traverse_names(n))}
                for n in schedule
            ],
        }
        for plan in plans[1:]:
            record = description["traverses"][plan.name]
            record["season_night"] = int(plan.name.split("_")[1])
            if plan.carried:
                record["carried"] = list(plan.carried)
    return description


def _describe_nights(
    description: dict,
    plans: list,
    scenes: dict[str, SynthScene],
    night_scenes: dict[str, SynthScene],
    night_names: Sequence[str],
) -> None:
    """Each night traverse's night, and each night's conditions and traverses, into ``description``."""
    for plan in plans[1:]:
        description["traverses"][plan.name]["night"] = scenes[plan.name].night_name
    description["nights"] = {
        name: {
            **night_scenes[name].describe_night(),
            "traverses": [night_traverse_name(drive, name) for drive in NIGHT_DRIVES],
        }
        for name in night_names
    }


# long: its docstring documents every argument (45 lines); the body plans, renders and describes in 53
def make_dataset(
    world: str,
    out_dir: str | os.PathLike,
    seed: int = DEFAULT_SEED,
    darkness: float = DEFAULT_DARKNESS,
    *,
    camera: Camera | None = None,
    overwrite: bool = False,
    threads: int | None = None,
    view: str = "panoramic",
    tilt_deg: float = 0.0,
    height_std: float = 0.0,
    pattern: str = "rows",
    parents: bool = False,
    nights: str | Sequence[str] | None = None,
    season: int | None = None,
    test_every: int = 3,
    bad_nights: str | Mapping[int, str] | None = None,
) -> dict[str, Path]:
    """Renders every traverse of ``world`` into ``out_dir`` and returns their folders by name.

    Args:
        world: ``"garden"`` (day_reference, night_reference, night_query), ``"living_room"``
            (day_reference, night_query) or ``"large_garden"`` (day_reference, night_query; 25 x 15
            m, about 1000 frames, rendered on demand only).
        out_dir: the dataset folder (its parent must exist, unless ``parents``); each traverse goes to
            ``out_dir/<traverse>`` (``images/`` + ``poses.csv`` + ``odometry.csv``: realistic
            wheel odometry between consecutive frames, :data:`SYNTH_WHEEL_NOISE`, its own seeded
            noise per traverse; the exact motions follow from ``poses.csv``; both files end with
            the frames' ``timestamp``), the description to ``out_dir/dataset.json``.
        seed: same seed -> byte-identical images.
        darkness: night darkness in [0, 3] (default 1.0; see :mod:`nightloc.synth.sensor`).
        camera: panorama size and optics (default 192 x 96, elevations +50..-30 degrees).
        overwrite: replace a dataset that exists at ``out_dir`` (else FileExistsError).
        threads: render threads (default all cores; the images do not depend on it).
        view: ``"panoramic"`` or ``"forward"``: each frame cut to the panorama's forward 90 degrees
            (columns within +-width/8 of the heading, left to right), and the day reference driven
            four times, looking along its path and at 90, 180 and 270 degrees to it (a forward
            camera's map needs references facing several ways; docs/localization.md).
        tilt_deg: std of each frame's camera pitch and roll, degrees (a robot on a lawn), 0 none.
        height_std: std of each frame's camera height about the world's, metres, 0 none.
        pattern: the large garden's mowing pattern: ``"rows"`` (along x, the default) or
            ``"columns"`` (along y, with another night drive: a second lawn layout to test on).
        parents: create the missing parent folders of ``out_dir`` (removed again on failure).
        nights: None (the default): the traverses of the paper's Table I. Otherwise the nights to
            render (:data:`~nightloc.synth.nights.NIGHT_NAMES`, a sequence or a comma-separated
            string; ``"all"`` every one): the day reference, then each night's re-drive of the day
            path and its other path (:func:`~nightloc.synth.paths.plan_night_drives`) as
            ``night_reference_<night>`` and ``night_query_<night>`` (``lamps``, the usual night:
            ``night_reference`` and ``night_query``, the garden's byte-identical to Table I's), each
            night recorded in ``dataset.json`` under ``nights``. An unknown name is a ValueError
            naming the choices.
        season: None (the default) or a number of nights N: instead of the night traverses, a
            season of the garden or the large garden (:mod:`nightloc.synth.season`): the day
            reference, then per night ``season_NNN`` (the day path driven again, with its own wheel
            odometry) and every ``test_every`` nights ``season_NNN_query`` (the other path); each
            night's conditions in ``dataset.json`` under ``season``. ``bad_nights``: bad nights of
            the season, ``{night: kind}`` or ``"10:covered,17:kidnapped,24:other_garden"``.

    The dataset is written as one set (:func:`nightloc.io.atomic.output_set`): the traverses and
    ``dataset.json`` appear together, or -- on an error or an interruption -- the previous
    dataset stays whole. A folder holding files nightloc did not write is refused, and another
    process writing the same ``out_dir`` makes this call raise BlockingIOError.
    """
    if world not in ALL_WORLDS:
        raise ValueError(f"unknown world {world!r}; choose one of {', '.join(ALL_WORLDS)}")
    if view not in ("panoramic", "forward"):
        raise ValueError(f"view must be 'panoramic' or 'forward', got {view!r}")
    for name, value in (("tilt_deg", tilt_deg), ("height_std", height_std)):
        if not (np.isfinite(value) and 0 <= value <= 20):
            raise ValueError(f"{name} must be in [0, 20], got {value}")
    night_names = None if nights is None else parse_nights(nights)
    if season is not None and (night_names is not None or pattern != "rows" or view != "panoramic"):
        raise ValueError(
            "a season (season=N) drives the day path and the other path of the rows pattern with a panorama: "
            "not with nights, pattern or a forward view"
        )
    schedule = None if season is None else plan_season(world, season, seed, test_every=test_every, bad=bad_nights)
    scene = SynthScene(world, seed, darkness, camera)
    plans, scenes, night_scenes, season_of = _plan_drives(world, scene, pattern, night_names, schedule, view)
    with output_set(
        out_dir, command="synth", overwrite=overwrite, overwrite_hint="overwrite=True", parents=parents
    ) as out:
        lit: dict[int, SynthScene] = {}  # the season night being rendered: its scene, made once
        lamps: dict[int, list[dict]] = {}  # the lamps on, by season night
        for plan in plans:
            plan_scene = scenes.get(plan.name, scene)
            if plan.name in season_of:
                night = season_of[plan.name]
                if night.night not in lit:
                    lit = {night.night: scene.season_night(night)}
                    lamps[night.night] = lamps_on(lit[night.night].world)
                plan_scene = lit[night.night]
            frames = progress(
                plan_scene.render_plan(plan, threads, tilt_deg, height_std),
                total=len(plan.positions),
                desc=f"{world}/{plan.name}",
                unit="frame",
            )
            if view == "forward":
                frames = (forward_view(frame) for frame in frames)
            odometry = SYNTH_WHEEL_NOISE.simulate(plan.positions, plan.headings, scene.odometry_rng(plan.name))
            for k in plan.carried:  # carried: the wheels did not turn
                odometry[k] = RobotMotion(0.0, 0.0, 0.0)
            save_traverse(
                out / plan.name,
                frames,
                positions=plan.positions,
                headings=plan.headings,
                odometry=odometry,
                timestamps=plan.timestamps(),
            )
        description = _describe_dataset(scene, plans, view, tilt_deg, height_std, pattern, schedule, lamps, test_every)
        if night_names is not None:
            _describe_nights(description, plans, scenes, night_scenes, night_names)
        _write_json_atomic(out / "dataset.json", description)
    return {plan.name: Path(out_dir) / plan.name for plan in plans}


def forward_view(panorama: np.ndarray) -> np.ndarray:
    """A forward camera's image cut from a panorama: the columns within +-width/8 of the heading
    (column 0), left to right: ``(H, W/4, ...)``."""
    width = panorama.shape[1]
    return np.roll(panorama, width // 8, axis=1)[:, : width // 4]


def _four_ways(plan: TraversePlan) -> TraversePlan:
    """The plan driven four times: along its headings and turned by 90, 180 and 270 degrees."""
    turns = np.repeat(np.arange(4) * (np.pi / 2), len(plan.positions))
    headings = np.angle(np.exp(1j * (np.tile(plan.headings, 4) + turns)))
    return TraversePlan(plan.name, plan.condition, np.tile(plan.positions, (4, 1)), headings)


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/nightloc`` or ``~/.cache/nightloc``."""
    base = os.environ.get("XDG_CACHE_HOME")
    return (Path(base) if base else Path.home() / ".cache") / "nightloc"


def _complete(folder: Path) -> bool:
    """True when ``folder`` holds every world's dataset.json and traverses, whole; False for
    anything missing or damaged (then the cache is rebuilt)."""
    for world in WORLD_NAMES:
        try:
            with open_regular(folder / world / "dataset.json", "dataset description", ValueError) as stream:
                content = json.loads(stream.read(1 << 20).decode("utf-8"))
            traverses = content["traverses"]
            if not isinstance(traverses, dict) or set(traverses) != set(TRAVERSE_NAMES[world]):
                return False
            for name, info in traverses.items():
                images = folder / world / name / "images"
                if not (folder / world / name / "poses.csv").is_file() or not images.is_dir():
                    return False
                if not (folder / world / name / "odometry.csv").is_file():  # caches written before odometry.csv
                    return False
                with open_regular(folder / world / name / "poses.csv", "poses file", ValueError) as stream:
                    if b"timestamp" not in stream.readline(4096):  # caches written before the frames' times
                        return False
                if not isinstance(info, dict) or len(os.listdir(images)) != info.get("frames"):
                    return False
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            return False
    return True


def default_dataset(cache_dir: str | os.PathLike | None = None) -> dict[str, dict[str, Path]]:
    """The default synthetic dataset, generated once into the user cache; its traverse folders.

    Returns ``{"garden": {"day_reference": Path, "night_reference": Path, "night_query": Path},
    "living_room": {"day_reference": Path, "night_query": Path}}``, generated with
    :data:`DEFAULT_SEED` and :data:`DEFAULT_DARKNESS` into
    ``<cache_dir>/synth-v<GENERATOR_VERSION>-seed<DEFAULT_SEED>/<world>/`` (``cache_dir``
    defaults to :func:`default_cache_dir`, created when missing). The folder appears atomically:
    a half-generated dataset (interrupted, or being generated by another process, which this
    call waits for) is never returned, and a damaged one (a file missing or garbled) is
    generated again.
    """
    root = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    folder = root / f"synth-v{GENERATOR_VERSION}-seed{DEFAULT_SEED}"
    if not _complete(folder):
        make_folder(root)  # the cache is nightloc's own: its parents may be created
        with locked_target(folder, wait=None) as target:  # one generator at a time; others wait
            if not _complete(target):  # not finished by another process meanwhile
                staging = staging_folder(target)
                try:
                    for world in WORLD_NAMES:
                        make_dataset(world, staging / world, DEFAULT_SEED, DEFAULT_DARKNESS)
                    replace_folder(staging, target)  # a damaged cache is replaced whole
                except BaseException:
                    shutil.rmtree(staging, ignore_errors=True)
                    raise
    return {world: {name: folder / world / name for name in TRAVERSE_NAMES[world]} for world in WORLD_NAMES}
