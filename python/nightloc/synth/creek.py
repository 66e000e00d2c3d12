"""The creek: a 500 m unlit bushland path walked by day and on a moonless night (the paper's
Creek experiment, its Table I: a day reference of 272 frames, a night query of 315).

:func:`build_creek` lays out a straight dirt path along ``y = 0`` (``|y| < PATH_HALF_WIDTH``)
through bushland: leaf litter and dry grass on both sides, rocks and logs along the path's edges,
shrubs, eucalypt-like trees near and far (trunks and canopies of several sizes), and, every
60-120 m, a structure: a footbridge's railings, a bench, a signpost, a small shelter or a stretch
of post-and-rail fence. There are no lamps: at night only the dark sky lights the scene.

:func:`creek_drive` plans a walk with a forward camera (a person carrying it at 1.4 m, or a tall
robot): ``frames`` frames evenly spaced from x = 5 m to ``length - 5`` m, with jitter along the
path, sideways and in heading. The day walk (272 frames, one every 1.8 m) and the night walk
(315 frames, one every 1.6 m: another walking speed at the same frame rate, a little to the side)
do not correspond frame by frame; their ``poses.csv`` give the ground truth (``nightloc route
DAY NIGHT --ground-truth positions --tolerance 3``) and their ``odometry.csv`` a noisy odometry.

:func:`make_creek_dataset` renders both into traverse folders as one output set. The scene, its
lighting and sensor are those of :mod:`nightloc.synth.routes` (:class:`RouteScene`,
:func:`render_drive`); docs/camera_study.md says how the rendered creek differs from the real one.
"""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..io.atomic import output_set, write_text
from ..io.traverse import save_traverse
from ..progress import progress
from .dataset import SYNTH_WHEEL_NOISE
from .geometry import Cylinder, Solid, box
from .routes import CAMERA_HEIGHT, Drive, RouteScene, path_length, render_drive
from .sensor import MAX_DARKNESS
from .textures import TextureLibrary, fbm, jitter_colour, value_noise
from .world import GroundMap, World

__all__ = [
    "CREEK_DARKNESS",
    "CREEK_FRAMES",
    "CREEK_FULL_WELL",
    "CREEK_LENGTH_M",
    "PATH_HALF_WIDTH",
    "build_creek",
    "creek_drive",
    "make_creek_dataset",
]

#: Length of the path, metres.
CREEK_LENGTH_M = 500.0
#: Half the width of the dirt path, metres.
PATH_HALF_WIDTH = 0.9
#: Frames of each walk (the paper's Table I).
CREEK_FRAMES = {"day_reference": 272, "night_query": 315}
#: The night's darkness (:mod:`nightloc.synth.sensor`): 10**-5 of the electrons of a metered
#: exposure; a moonless sky (about 0.002 lux) exposed 1/8 s at walking pace (docs/camera_study.md).
CREEK_DARKNESS = 2.5
#: The walking camera's pixel: a large-well full-frame sensor (8 um pixels, the paper's Sony
#: alpha 7S class), full well and read noise in electrons.
CREEK_FULL_WELL, CREEK_READ_NOISE = 64000.0, 2.0
#: Where each walk keeps: metres left of the path's centre line.
DAY_LANE, NIGHT_LANE = -0.25, 0.15
#: Seconds between frames: the day walk covers 1.8 m a frame (1.2 m/s), the night walk 1.56 m
#: (1.04 m/s, a slower walk in the dark).
FRAME_PERIOD_S = 1.5


def _creek_ground(rng: np.random.Generator, length: float) -> GroundMap:
    ppm = 10.0
    x0, y0, x1, y1 = -30.0, -30.0, length + 30.0, 30.0
    rows, cols = int((y1 - y0) * ppm), int((x1 - x0) * ppm)
    ys = np.repeat((y0 + (np.arange(rows) + 0.5) / ppm)[:, None], cols, axis=1)
    blotch = fbm(rng, rows, cols, max(4, rows // 30), max(4, cols // 30), octaves=4)
    fine = value_noise(rng, rows, cols, rows // 3, cols // 3)
    litter_dark, litter_light = np.array([0.10, 0.08, 0.05], np.float32), np.array([0.30, 0.24, 0.14], np.float32)
    grass = np.array([0.28, 0.27, 0.12], np.float32)
    shade = np.clip(0.8 * blotch + 0.5 * fine - 0.2, 0, 1)[..., None]
    albedo = litter_dark + (litter_light - litter_dark) * shade
    dry = np.clip((fbm(rng, rows, cols, max(4, rows // 20), max(4, cols // 60), octaves=3) - 0.55) * 4, 0, 1)
    albedo = albedo * (1 - dry[..., None]) + grass * (0.7 + 0.5 * fine)[..., None] * dry[..., None]
    # The path wanders a little inside its strip; its edge is ragged.
    edge = PATH_HALF_WIDTH + 0.25 * (value_noise(rng, rows, cols, 2, max(4, cols // 40)) - 0.5)
    centre = 0.15 * (value_noise(rng, rows, cols, 1, max(4, cols // 80)) - 0.5)
    dirt = np.array([0.42, 0.34, 0.24], np.float32) * (0.8 + 0.35 * fine)[..., None]
    on_path = np.abs(ys - centre) < edge
    albedo = np.where(on_path[..., None], dirt, albedo)
    return GroundMap(np.ascontiguousarray(albedo, dtype=np.float32), x0, y0, ppm)


# long: a world builder: the list of the creek's materials and objects, one after the other
def build_creek(seed: int = 0, length: float = CREEK_LENGTH_M) -> World:
    """The creek world (see the module docstring): ``length`` metres of path along +x."""
    length = path_length(seed, length)
    rng = np.random.default_rng([int(seed), 31])
    material = TextureLibrary(rng, ppm=60.0)
    tex = material.textures

    canopies = [
        material(
            f"canopy_{i}", "foliage", 3.0, 2.0, dark=jitter_colour(rng, d, 0.2), light=jitter_colour(rng, lit, 0.2)
        )
        for i, (d, lit) in enumerate(
            [
                ((0.03, 0.07, 0.03), (0.17, 0.26, 0.12)),
                ((0.05, 0.07, 0.04), (0.24, 0.28, 0.16)),
                ((0.02, 0.06, 0.04), (0.12, 0.22, 0.14)),
            ]
        )
    ]
    shrubs = [
        material(
            f"shrub_{i}",
            "foliage",
            2.0,
            1.5,
            dark=jitter_colour(rng, (0.03, 0.08, 0.02), 0.25),
            light=jitter_colour(rng, (0.16, 0.30, 0.08), 0.25),
            flowers=f,
            flower=(0.9, 0.85, 0.2),
        )
        for i, f in enumerate((0.0, 0.06))
    ]
    barks = [
        material("bark_grey", "bark", 1.0, 2.0, colour=(0.42, 0.40, 0.36)),
        material("bark_dark", "bark", 1.0, 2.0, colour=(0.16, 0.11, 0.08)),
        material("bark_pale", "plain", 1.0, 2.0, colour=(0.70, 0.68, 0.62), noise=0.3),
    ]
    rock = material("rock", "plain", 1.0, 1.0, colour=(0.38, 0.36, 0.33), noise=0.45)
    log = material("log", "bark", 2.0, 0.5, colour=(0.25, 0.19, 0.13))
    timber = material("timber", "wood", 2.0, 1.0, colour=(0.38, 0.26, 0.15))
    grey_timber = material("grey_timber", "planks", 3.0, 1.2, colour=(0.45, 0.43, 0.40), plank=0.12, rails=())
    sign = material("sign", "plain", 0.6, 0.4, colour=(0.10, 0.30, 0.12), noise=0.05)
    roof = material("roof", "tiles", 3.0, 1.0, colour=(0.30, 0.30, 0.32))

    objects: list[Solid] = []
    # Trees: a dense band 2.5-12 m from the path and taller ones further back.
    x = -25.0
    while x < length + 25.0:
        for side in (-1.0, 1.0):
            if rng.random() < 0.75:
                near = rng.random() < 0.6
                distance = float(rng.uniform(2.5, 12.0) if near else rng.uniform(12.0, 28.0))
                tx, ty = x + float(rng.uniform(-1.5, 1.5)), side * distance
                trunk = float(rng.uniform(0.12, 0.45))
                crown_base = float(rng.uniform(2.5, 7.0))
                objects.append(
                    Cylinder(
                        (tx, ty),
                        trunk,
                        0.0,
                        crown_base + 1.0,
                        str(rng.choice(barks)),
                        u_offset=float(rng.uniform(0, 3)),
                    )
                )
                objects.append(
                    Cylinder(
                        (tx, ty),
                        float(rng.uniform(1.2, 4.0)),
                        crown_base,
                        crown_base + float(rng.uniform(3.0, 10.0)),
                        str(rng.choice(canopies)),
                        u_offset=float(rng.uniform(0, 3)),
                    )
                )
            if rng.random() < 0.6:  # understorey shrubs close to the path
                sx, sy = x + float(rng.uniform(-2.0, 2.0)), side * float(rng.uniform(1.6, 4.5))
                objects.append(
                    Cylinder(
                        (sx, sy),
                        float(rng.uniform(0.4, 1.2)),
                        0.0,
                        float(rng.uniform(0.6, 2.2)),
                        str(rng.choice(shrubs)),
                        u_offset=float(rng.uniform(0, 2)),
                    )
                )
            if rng.random() < 0.25:  # rocks and fallen logs on the path's edges
                ex, ey = x + float(rng.uniform(-2.0, 2.0)), side * float(rng.uniform(PATH_HALF_WIDTH + 0.3, 1.6))
                if rng.random() < 0.6:
                    objects.append(
                        Cylinder((ex, ey), float(rng.uniform(0.15, 0.45)), 0.0, float(rng.uniform(0.15, 0.5)), rock)
                    )
                else:
                    long = float(rng.uniform(1.0, 3.0))
                    objects.append(box(ex - long / 2, ey - 0.12, ex + long / 2, ey + 0.12, 0.0, 0.25, log))
        x += float(rng.uniform(3.0, 6.0))
    # A structure every 60-120 m.
    x = float(rng.uniform(20.0, 60.0))
    while x < length - 10.0:
        kind = rng.choice(["bridge", "bench", "sign", "shelter", "fence"])
        side = 1.0 if rng.random() < 0.5 else -1.0
        if kind == "bridge":  # railings both sides of the path for 6-10 m
            span = float(rng.uniform(6.0, 10.0))
            for s in (-1.0, 1.0):
                y = s * (PATH_HALF_WIDTH + 0.15)
                objects.append(box(x, y - 0.05, x + span, y + 0.05, 0.85, 1.0, timber))
                for post in np.arange(x, x + span + 0.01, 2.0):
                    objects.append(box(post - 0.05, y - 0.05, post + 0.05, y + 0.05, 0.0, 1.0, timber))
        elif kind == "bench":
            y = side * (PATH_HALF_WIDTH + 0.8)
            objects.append(box(x, min(y, y + side * 0.45), x + 1.8, max(y, y + side * 0.45), 0.4, 0.48, timber))
            objects.append(box(x, y + side * 0.4 - 0.04, x + 1.8, y + side * 0.4 + 0.04, 0.48, 0.9, timber))
        elif kind == "sign":
            y = side * (PATH_HALF_WIDTH + 0.5)
            objects.append(box(x - 0.05, y - 0.05, x + 0.05, y + 0.05, 0.0, 1.6, timber))
            objects.append(box(x - 0.3, y - 0.02, x + 0.3, y + 0.02, 1.2, 1.6, sign))
        elif kind == "shelter":
            y0 = side * (PATH_HALF_WIDTH + 2.0)
            y1 = side * (PATH_HALF_WIDTH + 5.0)
            lo, hi = min(y0, y1), max(y0, y1)
            for cx in (x, x + 3.8):
                for cy in (lo, hi - 0.1):
                    objects.append(box(cx, cy, cx + 0.1, cy + 0.1, 0.0, 2.4, timber))
            back = hi - 0.1 if side > 0 else lo
            objects.append(box(x, back, x + 3.9, back + 0.1, 0.0, 2.4, grey_timber))
            objects.append(box(x - 0.3, lo - 0.3, x + 4.2, hi + 0.3, 2.4, 2.55, roof))
        else:  # post-and-rail fence along the path
            span = float(rng.uniform(10.0, 25.0))
            y = side * (PATH_HALF_WIDTH + float(rng.uniform(0.6, 1.5)))
            for height in (0.45, 0.95):
                objects.append(box(x, y - 0.04, x + span, y + 0.04, height, height + 0.1, grey_timber))
            for post in np.arange(x, x + span + 0.01, 2.5):
                objects.append(box(post - 0.06, y - 0.06, post + 0.06, y + 0.06, 0.0, 1.15, grey_timber))
        x += float(rng.uniform(60.0, 120.0))
    return World(
        "creek",
        objects,
        tex,
        _creek_ground(rng, length),
        (0.0, -PATH_HALF_WIDTH, length, PATH_HALF_WIDTH),
        False,
        CAMERA_HEIGHT,
        {},
        int(seed),
    )


def creek_drive(world: World, condition: str, frames: int, lane: float, seed: int) -> Drive:
    """A walk of ``frames`` frames along the creek ``lane`` metres left of the centre line: frame
    ``i`` at ``x = 5 + i * spacing`` (``spacing = (length - 10) / (frames - 1)``) plus a uniform
    jitter of +-0.2 spacing, with a sideways wobble of 0.08 m and a heading wobble of 2 degrees
    (standard deviations), drawn from ``seed``."""
    if condition not in ("day", "night"):
        raise ValueError(f"condition must be 'day' or 'night', got {condition!r}")
    if frames < 2:
        raise ValueError(f"a walk needs at least 2 frames, got {frames}")
    rng = np.random.default_rng([int(seed), 37, frames])
    length = world.mapped_area[2]
    spacing = (length - 10.0) / (frames - 1)
    xs = 5.0 + spacing * np.arange(frames) + rng.uniform(-0.2, 0.2, frames) * spacing
    ys = lane + rng.normal(0.0, 0.08, frames)
    headings = rng.normal(0.0, np.radians(2.0), frames)
    positions = np.stack([xs, ys], axis=1)
    world.check_camera_positions(positions)
    return Drive(positions, headings, np.zeros(frames), condition, float(lane), int(seed))


def make_creek_dataset(
    out_dir: str | os.PathLike,
    seed: int = 0,
    darkness: float = CREEK_DARKNESS,
    *,
    overwrite: bool = False,
    parents: bool = False,
    frames: dict[str, int] | None = None,
) -> dict[str, Path]:
    """Renders the creek's day reference and night query into ``out_dir`` (one output set) and
    returns their folders by name.

    Each is ``out_dir/<traverse>/images/`` (forward camera, 96 x 96) + ``poses.csv`` (``x, y,
    heading`` and the frame times, one frame every :data:`FRAME_PERIOD_S`: the ground truth) +
    ``odometry.csv`` (the walk's odometry with the synthetic drives' noise,
    :data:`~nightloc.synth.dataset.SYNTH_WHEEL_NOISE`: 3 % scale and 3 % per step, what route mode
    predicts by); ``out_dir/dataset.json`` describes the world, the walks and the darkness.
    ``frames`` sets other frame counts per traverse (default :data:`CREEK_FRAMES`), spread over the
    same 490 m.
    """
    if not (np.isfinite(darkness) and 0.0 <= darkness <= MAX_DARKNESS):
        raise ValueError(f"darkness must be a number in [0, {MAX_DARKNESS:g}], got {darkness!r}")
    counts = dict(CREEK_FRAMES) if frames is None else dict(frames)
    if set(counts) != set(CREEK_FRAMES) or not all(isinstance(n, int) and n >= 2 for n in counts.values()):
        raise ValueError(f"frames must give day_reference and night_query at least 2 frames each, got {frames!r}")
    world = build_creek(seed)
    scene = RouteScene(world, seed, darkness)
    # the large pixel collects CREEK_FULL_WELL / FULL_WELL times the electrons (metered_exposure)
    night = scene.exposure["night"]
    scene.exposure["night"] = replace(
        night,
        electrons_per_unit=night.electrons_per_unit * CREEK_FULL_WELL / night.full_well,
        full_well=CREEK_FULL_WELL,
        read_noise=CREEK_READ_NOISE,
    )
    walks = {
        "day_reference": creek_drive(world, "day", counts["day_reference"], DAY_LANE, seed),
        "night_query": creek_drive(world, "night", counts["night_query"], NIGHT_LANE, seed + 1),
    }
    with output_set(
        out_dir, command="synth", overwrite=overwrite, overwrite_hint="overwrite=True", parents=parents
    ) as out:
        for index, (name, walk) in enumerate(walks.items()):
            images = progress(
                (render_drive(scene, _one(walk, i), "forward")[0] for i in range(len(walk.positions))),
                total=len(walk.positions),
                desc=f"creek/{name}",
                unit="frame",
            )
            save_traverse(
                out / name,
                images,
                positions=walk.positions,
                headings=walk.headings,
                odometry=SYNTH_WHEEL_NOISE.simulate(
                    walk.positions, walk.headings, np.random.default_rng([int(seed), 41, index])
                ),
                timestamps=1.0 + np.arange(len(walk.positions)) * FRAME_PERIOD_S,
            )
        description = {
            "generator": "nightloc.synth.creek",
            "world": "creek",
            "seed": int(seed),
            "darkness": float(darkness),
            "night_sensor": {"full_well_e": CREEK_FULL_WELL, "read_noise_e": CREEK_READ_NOISE},
            "odometry": {
                "scale_std": SYNTH_WHEEL_NOISE.scale_std,
                "distance_std": SYNTH_WHEEL_NOISE.distance_std,
                "turn_std_rad": SYNTH_WHEEL_NOISE.turn_std,
            },
            "length_m": CREEK_LENGTH_M,
            "camera": {"view": "forward", "width": 96, "height": 96, "height_above_ground_m": CAMERA_HEIGHT},
            "traverses": {
                name: {"condition": walk.condition, "frames": int(len(walk.positions)), "lane_m": walk.offset}
                for name, walk in walks.items()
            },
        }
        write_text(out / "dataset.json", json.dumps(description, indent=2) + "\n")
    return {name: Path(out_dir) / name for name in walks}


def _one(walk: Drive, index: int) -> Drive:
    """Frame ``index`` of ``walk`` as a one-frame walk whose noise seed is the frame's own."""
    return Drive(
        walk.positions[index : index + 1],
        walk.headings[index : index + 1],
        walk.pitches[index : index + 1],
        walk.condition,
        walk.offset,
        int(walk.seed) * 100003 + index,
    )
