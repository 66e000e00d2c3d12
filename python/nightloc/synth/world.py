"""The two synthetic worlds: a 7 x 5 m garden lawn and a 6 x 3 m living-room floor.

A :class:`~nightloc.synth.scene.World` is geometry (vertical prisms, see
:mod:`nightloc.synth.geometry`), textures (:mod:`nightloc.synth.textures`), a ground albedo map,
light sources and the *mapped area* the robot drives in. Layouts are fixed by hand, like the
paper's sites; the seed only changes the textures' random details (board tints, leaf blotches,
paintings...).

World frame: metres, x right (east), y up (north), z up; the mapped area starts at (0, 0).
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from .geometry import Cylinder, Solid, box, panel
from .large_garden import large_garden
from .scene import GroundMap, LightSource, World
from .textures import TextureLibrary, fbm, jitter_colour, value_noise

__all__ = ["ALL_WORLDS", "WORLD_NAMES", "GroundMap", "LightSource", "World", "build_world"]

#: The worlds of the default dataset.
WORLD_NAMES: tuple[str, ...] = ("garden", "living_room")
#: Every world, with those rendered on demand only (the 25 x 15 m large garden).
ALL_WORLDS: tuple[str, ...] = (*WORLD_NAMES, "large_garden")

# --- garden ------------------------------------------------------------------------------------


def _garden_ground(rng: np.random.Generator) -> GroundMap:
    ppm = 50.0
    x0, y0, x1, y1 = -1.5, -1.5, 8.5, 6.8
    rows, cols = int((y1 - y0) * ppm), int((x1 - x0) * ppm)
    xs, ys = np.meshgrid(x0 + (np.arange(cols) + 0.5) / ppm, y0 + (np.arange(rows) + 0.5) / ppm)
    blotch = fbm(rng, rows, cols, 8, 10, octaves=4)
    fine = value_noise(rng, rows, cols, rows // 2, cols // 2)
    grass_dark, grass_light = np.array([0.05, 0.16, 0.03], np.float32), np.array([0.13, 0.30, 0.06], np.float32)
    albedo = grass_dark + (grass_light - grass_dark) * np.clip(0.7 * blotch + 0.5 * fine - 0.1, 0, 1)[..., None]
    mowing = np.where((np.floor((ys - y0) / 0.55) % 2) == 0, 1.12, 0.88)  # mowing stripes along x
    albedo *= mowing[..., None]
    worn = fbm(rng, rows, cols, 5, 6, octaves=3)
    albedo = np.where((worn > 0.72)[..., None], albedo * 0.5 + np.array([0.17, 0.13, 0.07], np.float32) * 0.6, albedo)
    soil = np.array([0.11, 0.07, 0.04], np.float32) * (0.7 + 0.6 * fine)[..., None]
    beds = (xs < -0.9) | (xs > 7.7) | (ys < -0.9)
    beds |= (xs - 3.3) ** 2 + (ys + 1.0) ** 2 < 0.8**2  # mulch circle round the small tree
    albedo = np.where(beds[..., None], soil, albedo)
    slabs_x, slabs_y = np.floor((xs + 7) / 0.6), np.floor((ys - 5.8) / 0.6)
    slab_tint = 0.8 + 0.35 * rng.random(64)[((slabs_x * 7 + slabs_y * 13) % 64).astype(int)]
    patio = ys > 5.8
    paving = np.array([0.45, 0.42, 0.38], np.float32) * slab_tint[..., None]
    joint = (((xs + 7) % 0.6) < 0.015) | (((ys - 5.8) % 0.6) < 0.015)
    paving[joint] *= 0.4
    albedo = np.where(patio[..., None], paving, albedo)
    # stepping stones from the patio to the shed door, across the lawn's east side
    stones = np.zeros((rows, cols), np.uint8)
    for t in np.linspace(0.06, 0.94, 8):
        cx, cy = 5.4 + t * (7.2 - 5.4), 5.8 + t * (0.9 - 5.8)
        tint = tuple(float(v) for v in np.array([0.50, 0.47, 0.43]) * rng.uniform(0.8, 1.15))
        centre = (int((cx - x0) * ppm), int((cy - y0) * ppm))
        axes, angle = (int(0.22 * ppm), int(0.16 * ppm)), float(rng.uniform(0, 180))
        cv2.ellipse(albedo, centre, axes, angle, 0, 360, tint, -1)
        cv2.ellipse(stones, centre, axes, angle, 0, 360, 1, -1)
    lawn = ~beds & ~patio & (stones == 0)
    stripes = np.where(lawn, mowing, 1.0).astype(np.float32)
    return GroundMap(np.ascontiguousarray(albedo, dtype=np.float32), x0, y0, ppm, lawn, stripes)


# long: a world builder: the list of the garden's materials and objects, one after the other
def _garden(seed: int) -> World:
    rng = np.random.default_rng([seed, 1])
    material = TextureLibrary(rng, ppm=100.0)
    tex = material.textures

    fence_a = material("fence_a", "planks", 4.0, 1.8, colour=jitter_colour(rng, (0.33, 0.20, 0.11)))
    fence_b = material("fence_b", "planks", 4.0, 1.8, colour=jitter_colour(rng, (0.42, 0.30, 0.18)), plank=0.15)
    post = material("post", "wood", 0.5, 2.0, colour=(0.22, 0.14, 0.08))
    brick = material("brick", "brick", 4.5, 3.2)
    roof = material("roof", "tiles", 4.0, 1.0)
    siding = material(
        "shed", "planks", 4.0, 2.1, colour=(0.20, 0.30, 0.22), plank=0.12, gap=0.01, rails=(), vertical=False
    )
    shed_roof = material("shed_roof", "plain", 2.0, 2.0, colour=(0.12, 0.12, 0.13))
    door = material("door", "panels", 0.9, 2.0, colour=(0.08, 0.18, 0.35))
    shed_door = material("shed_door", "panels", 0.8, 1.8, colour=(0.55, 0.45, 0.30))
    bark = material("bark", "bark", 1.0, 2.0)
    stone = material("stone", "plain", 1.0, 1.0, colour=(0.45, 0.43, 0.40), noise=0.4)
    bed = material("bed", "planks", 2.0, 0.3, colour=(0.30, 0.22, 0.15), plank=0.3, rails=(), vertical=False)
    metal = material("metal", "plain", 0.5, 1.0, colour=(0.15, 0.15, 0.16))
    lamp = material("lamp", "plain", 0.5, 0.3, colour=(0.9, 0.85, 0.7), noise=0.05)
    leaves = [
        material(
            f"leaves_{i}",
            "foliage",
            3.0,
            2.0,
            dark=jitter_colour(rng, d, 0.2),
            light=jitter_colour(rng, lit, 0.2),
            flowers=f,
            flower=fc,
        )
        for i, (d, lit, f, fc) in enumerate(
            [
                ((0.03, 0.10, 0.02), (0.16, 0.36, 0.07), 0.0, (1, 1, 1)),
                ((0.02, 0.07, 0.03), (0.09, 0.25, 0.08), 0.0, (1, 1, 1)),
                ((0.04, 0.10, 0.02), (0.20, 0.33, 0.05), 0.25, (0.85, 0.8, 0.15)),
                ((0.05, 0.08, 0.02), (0.24, 0.30, 0.08), 0.3, (0.75, 0.12, 0.20)),
                ((0.02, 0.09, 0.04), (0.10, 0.30, 0.15), 0.15, (0.85, 0.85, 0.9)),
                ((0.06, 0.09, 0.03), (0.30, 0.32, 0.10), 0.0, (1, 1, 1)),
            ]
        )
    ]
    windows = [material(f"window_{i}", "window", 1.2, 1.2, panes=(2, 2) if i % 2 else (3, 2)) for i in range(3)]

    objects: list[Solid] = []
    # Fences (west, south, east) with posts every ~2 m; the house closes the north side.
    objects.append(box(-1.56, -1.5, -1.5, 6.8, 0.0, 1.8, fence_a))
    objects.append(box(-1.5, -1.56, 8.5, -1.5, 0.0, 1.8, fence_a, u_offset=1.3))
    objects.append(box(8.5, -1.5, 8.56, 6.8, 0.0, 1.5, fence_b))
    for y in np.arange(-1.5, 6.9, 2.1):
        objects.append(box(-1.5, y - 0.05, -1.42, y + 0.05, 0.0, 1.95, post))
        objects.append(box(8.42, y - 0.05, 8.5, y + 0.05, 0.0, 1.6, post))
    for x in np.arange(0.5, 8.5, 2.0):
        objects.append(box(x - 0.05, -1.5, x + 0.05, -1.42, 0.0, 1.95, post))
    # The house: brick wall with windows, a door and a porch lamp; a tiled roof above.
    objects.append(box(-1.5, 6.8, 8.5, 9.5, 0.0, 3.2, brick))
    objects.append(box(-1.8, 6.55, 8.8, 9.8, 3.2, 3.45, roof))
    for i, (x, w) in enumerate([(0.6, 1.4), (2.6, 1.0), (6.9, 1.6)]):
        objects.append(
            panel((x, 6.79), w, 0.02, -np.pi / 2, 0.9, 2.1, windows[i], emission="house_window" if i != 1 else None)
        )
    objects.append(panel((4.4, 6.79), 0.9, 0.02, -np.pi / 2, 0.0, 2.0, door))
    objects.append(Cylinder((5.2, 6.72), 0.07, 2.05, 2.3, lamp, emission="porch_lamp"))
    objects.append(Cylinder((8.2, 6.68), 0.05, 0.0, 3.2, metal))  # downpipe
    # Shed in the south-east corner, door facing west.
    objects.append(box(7.45, -1.45, 8.45, 0.65, 0.0, 2.1, siding))
    objects.append(box(7.35, -1.5, 8.5, 0.75, 2.1, 2.3, shed_roof))
    objects.append(panel((7.44, -0.4), 0.8, 0.02, np.pi, 0.0, 1.8, shed_door))
    # Raised vegetable bed along the south fence; hedge along the east fence.
    objects.append(box(0.9, -1.35, 2.9, -0.85, 0.0, 0.35, bed))
    objects.append(box(7.75, 1.3, 8.45, 5.3, 0.0, 1.3, leaves[1]))
    # Bench along the west fence.
    objects.append(box(-1.35, 1.6, -0.9, 3.2, 0.0, 0.45, bed))
    objects.append(box(-1.45, 1.6, -1.35, 3.2, 0.0, 0.9, bed))
    # Street lamp beyond the south-west corner.
    objects.append(Cylinder((-3.0, -4.0), 0.06, 0.0, 4.4, metal))
    objects.append(Cylinder((-3.0, -4.0), 0.25, 4.4, 4.65, lamp, emission="street_lamp"))
    # Birdbath on the lawn (pedestal and basin).
    objects.append(Cylinder((2.3, 3.85), 0.1, 0.0, 0.7, stone))
    objects.append(Cylinder((2.3, 3.85), 0.3, 0.7, 0.85, stone))
    # Trees: two in the garden, three beyond the fences (seen above them).
    for (cx, cy), trunk_r, trunk_top, canopy_r, canopy_z, leaf in [
        ((-0.7, 5.1), 0.14, 2.0, 1.1, (1.6, 4.2), leaves[0]),
        ((3.3, -1.0), 0.10, 1.6, 0.8, (1.3, 3.4), leaves[5]),
        ((11.5, 2.0), 0.30, 3.0, 2.4, (2.4, 7.5), leaves[1]),
        ((1.0, -5.5), 0.30, 3.0, 2.8, (2.2, 8.0), leaves[0]),
        ((-5.0, 1.0), 0.25, 2.5, 2.0, (2.0, 6.0), leaves[5]),
    ]:
        objects.append(Cylinder((cx, cy), trunk_r, 0.0, trunk_top, bark, u_offset=rng.uniform(0, 3)))
        objects.append(Cylinder((cx, cy), canopy_r, canopy_z[0], canopy_z[1], leaf, u_offset=rng.uniform(0, 3)))
    # Shrubs in the beds along the fences: different sizes, leaves and flowers.
    for cx, cy, r, h, k in [
        (-1.05, -0.6, 0.45, 1.1, 2),
        (-1.0, 0.7, 0.4, 0.8, 3),
        (-1.0, 4.0, 0.45, 1.4, 4),
        (0.3, -1.05, 0.4, 0.9, 4),
        (4.6, -1.05, 0.45, 1.2, 2),
        (5.9, -1.0, 0.5, 0.7, 3),
        (6.8, -1.1, 0.35, 1.0, 1),
        (8.0, 5.9, 0.45, 1.1, 3),
        (-1.0, 6.2, 0.4, 0.9, 2),
    ]:
        objects.append(Cylinder((cx, cy), r, 0.0, h, leaves[k], u_offset=rng.uniform(0, 3)))

    lights = {
        "porch_lamp": LightSource((5.2, 6.5, 2.15), (0.55, 0.42, 0.25), ("night",), glow=40.0),
        "house_window": LightSource((2.0, 6.4, 1.6), (0.25, 0.18, 0.10), ("night",), glow=0.25),
        "street_lamp": LightSource((-3.0, -4.0, 4.35), (2.0, 1.5, 0.8), ("night",), glow=40.0),
    }
    return World("garden", objects, tex, _garden_ground(rng), (0.0, 0.0, 7.0, 5.0), False, 0.3, lights, seed)


# --- living room -------------------------------------------------------------------------------


def _room_floor(rng: np.random.Generator) -> GroundMap:
    ppm = 50.0
    x0, y0, x1, y1 = -1.0, -0.9, 7.0, 3.9
    rows, cols = int((y1 - y0) * ppm), int((x1 - x0) * ppm)
    xs, ys = np.meshgrid(x0 + (np.arange(cols) + 0.5) / ppm, y0 + (np.arange(rows) + 0.5) / ppm)
    board = np.floor((ys - y0) / 0.14).astype(int)
    stagger = (board * 0.57) % 1.2
    plank = np.floor((xs - x0 + stagger) / 1.2).astype(int)
    tint = 0.75 + 0.45 * rng.random(4096)[(board * 37 + plank * 11) % 4096]
    grain = value_noise(rng, rows, cols, rows // 2, cols // 24)
    albedo = np.array([0.38, 0.22, 0.10], np.float32) * (tint * (0.8 + 0.35 * grain))[..., None]
    seams = (((ys - y0) % 0.14) < 0.01) | (((xs - x0 + stagger) % 1.2) < 0.01)
    albedo[seams] *= 0.45
    # A patterned rug under the coffee-table area and a runner by the kitchen.
    rug = (xs > 0.9) & (xs < 4.3) & (ys > 0.7) & (ys < 2.6)
    u, v = (xs - 0.9) / 3.4, (ys - 0.7) / 1.9
    border = (u < 0.06) | (u > 0.94) | (v < 0.09) | (v > 0.91)
    diamonds = (np.abs(((u * 6) % 1) - 0.5) + np.abs(((v * 3) % 1) - 0.5)) < 0.3
    rug_colour = np.where(
        border[..., None],
        np.array([0.45, 0.06, 0.05], np.float32),
        np.where(
            diamonds[..., None], np.array([0.65, 0.55, 0.30], np.float32), np.array([0.10, 0.12, 0.30], np.float32)
        ),
    )
    rug_colour *= (0.85 + 0.3 * value_noise(rng, rows, cols, rows // 3, cols // 3))[..., None]
    albedo = np.where(rug[..., None], rug_colour, albedo)
    runner = (xs > 4.9) & (xs < 6.7) & (ys > -0.2) & (ys < 0.35)
    stripes = (np.floor((xs - 4.9) / 0.12) % 2) == 0
    albedo = np.where(
        runner[..., None],
        np.where(stripes[..., None], np.array([0.6, 0.6, 0.55], np.float32), np.array([0.25, 0.35, 0.28], np.float32)),
        albedo,
    )
    return GroundMap(np.ascontiguousarray(albedo, dtype=np.float32), x0, y0, ppm)


# long: a world builder: the list of the living room's materials and objects, one after the other
def _living_room(seed: int) -> World:
    rng = np.random.default_rng([seed, 2])
    material = TextureLibrary(rng, ppm=100.0)
    tex = material.textures

    wall_cream = material("wall_cream", "paint", 4.0, 2.5, colour=(0.70, 0.64, 0.52), skirting=0.1)
    wall_blue = material("wall_blue", "paint", 4.0, 2.5, colour=(0.30, 0.40, 0.52), skirting=0.1)
    wallpaper = material(
        "wallpaper",
        "paint",
        4.0,
        2.5,
        colour=(0.62, 0.58, 0.48),
        stripes=0.2,
        stripe_colour=(0.45, 0.30, 0.25),
        skirting=0.1,
    )
    ceiling = material("ceiling", "plain", 2.0, 2.0, colour=(0.8, 0.8, 0.78), noise=0.06)
    sofa = material("sofa", "fabric", 2.5, 0.95, colour=(0.12, 0.18, 0.35))
    armchair = material("armchair", "fabric", 2.0, 0.9, colour=(0.45, 0.10, 0.08), seam=0.35)
    books = material("books", "books", 2.0, 2.0)
    cabinet = material("cabinet", "panels", 1.6, 0.5, colour=(0.35, 0.20, 0.10))
    kitchen = material("kitchen", "panels", 1.0, 0.9, colour=(0.80, 0.80, 0.76), handle=(0.2, 0.2, 0.2))
    wall_units = material("wall_units", "panels", 1.0, 0.7, colour=(0.80, 0.80, 0.76), handle=(0.2, 0.2, 0.2))
    oven = material("oven", "appliance", 0.6, 0.9)
    tv = material("tv", "screen", 1.2, 0.65)
    wood = material("wood", "wood", 1.0, 1.0, colour=(0.30, 0.17, 0.08))
    shade = material("shade", "plain", 1.0, 0.4, colour=(0.9, 0.85, 0.7), noise=0.05)
    metal = material("metal", "plain", 0.5, 2.0, colour=(0.1, 0.1, 0.1))
    curtain = material("curtain", "curtain", 1.0, 2.2, colour=(0.55, 0.35, 0.25))
    plant = material("plant", "foliage", 1.5, 1.0, dark=(0.02, 0.08, 0.02), light=(0.12, 0.35, 0.08))
    pot = material("pot", "plain", 1.0, 0.4, colour=(0.55, 0.25, 0.12), noise=0.2)
    pictures = [
        material(f"picture_{i}", "picture", w, h)
        for i, (w, h) in enumerate([(0.9, 0.6), (0.5, 0.7), (0.7, 0.5), (1.0, 0.7), (0.4, 0.4)])
    ]

    H = 2.5  # ceiling height
    xw, xe, ys_, yn = -1.0, 7.0, -0.9, 3.9  # inner faces of the walls
    t = 0.15  # wall thickness
    objects: list[Solid] = []
    # Ceiling slab over the whole room (its underside is what the camera sees).
    objects.append(box(xw - t, ys_ - t, xe + t, yn + t, H, H + 0.2, ceiling))
    # North, west and east walls; the south wall has two window openings.
    objects.append(box(xw - t, yn, xe + t, yn + t, 0.0, H, wall_cream))
    objects.append(box(xw - t, ys_, xw, yn, 0.0, H, wall_blue))
    objects.append(box(xe, ys_, xe + t, yn, 0.0, H, wallpaper))
    openings = [(0.5, 2.0), (3.5, 5.0)]
    sill, lintel = 0.9, 2.1
    edges = [xw - t] + [v for o in openings for v in o] + [xe + t]
    for i in range(0, len(edges), 2):
        objects.append(box(edges[i], ys_ - t, edges[i + 1], ys_, 0.0, H, wall_cream, u_offset=edges[i]))
    for x0, x1 in openings:
        objects.append(box(x0, ys_ - t, x1, ys_, 0.0, sill, wall_cream, u_offset=x0))
        objects.append(box(x0, ys_ - t, x1, ys_, lintel, H, wall_cream, u_offset=x0))
        for cx in (x0 - 0.18, x1 + 0.18):  # curtains drawn aside
            objects.append(
                panel((cx, ys_ + 0.03), 0.32, 0.05, np.pi / 2, 0.05, 2.3, curtain, u_offset=rng.uniform(0, 1))
            )
    # North wall: sofa with a backrest, two pictures, a floor lamp and a plant.
    objects.append(box(1.4, 3.25, 3.9, 3.65, 0.0, 0.45, sofa))
    objects.append(box(1.4, 3.65, 3.9, 3.9, 0.0, 0.9, sofa, u_offset=0.7))
    objects.append(box(1.2, 3.25, 1.4, 3.9, 0.0, 0.62, sofa))
    objects.append(box(3.9, 3.25, 4.1, 3.9, 0.0, 0.62, sofa))
    objects.append(panel((2.0, 3.88), 0.9, 0.02, -np.pi / 2, 1.3, 1.9, pictures[0]))
    objects.append(panel((3.3, 3.88), 0.5, 0.02, -np.pi / 2, 1.2, 1.9, pictures[1]))
    objects.append(Cylinder((4.6, 3.6), 0.025, 0.0, 1.4, metal))
    objects.append(Cylinder((4.6, 3.6), 0.2, 1.4, 1.72, shade, emission="floor_lamp"))
    objects.append(Cylinder((6.5, 3.45), 0.2, 0.0, 0.4, pot))
    objects.append(Cylinder((6.5, 3.45), 0.38, 0.4, 1.3, plant))
    # East wall: a bookcase and a picture.
    objects.append(panel((6.8, 1.5), 2.0, 0.38, np.pi, 0.0, 2.0, books))
    objects.append(panel((6.98, 3.0), 0.7, 0.02, np.pi, 1.2, 1.7, pictures[2]))
    # West wall: TV cabinet, TV, a table lamp, a picture; an armchair in the south-west corner.
    objects.append(panel((-0.78, 1.6), 1.6, 0.44, 0.0, 0.0, 0.5, cabinet))
    objects.append(panel((-0.9, 1.6), 1.2, 0.06, 0.0, 0.55, 1.2, tv))
    objects.append(Cylinder((-0.75, 2.25), 0.05, 0.5, 0.75, metal))
    objects.append(Cylinder((-0.75, 2.25), 0.15, 0.75, 0.98, shade, emission="table_lamp"))
    objects.append(panel((-0.98, 3.0), 0.4, 0.02, 0.0, 1.3, 1.7, pictures[4]))
    objects.append(box(-0.95, -0.85, -0.25, -0.2, 0.0, 0.45, armchair))
    objects.append(box(-0.95, -0.85, -0.25, -0.65, 0.0, 0.85, armchair, u_offset=0.5))
    # Kitchen corner (south-east): oven with a light, units, wall cupboards, a picture.
    objects.append(panel((5.75, -0.6), 0.6, 0.6, np.pi / 2, 0.0, 0.9, oven, emission="oven"))
    objects.append(panel((6.5, -0.6), 1.0, 0.6, np.pi / 2, 0.0, 0.9, kitchen))
    objects.append(box(5.4, -0.9, 7.0, -0.3, 0.9, 0.94, wood))
    objects.append(panel((6.2, -0.72), 1.6, 0.35, np.pi / 2, 1.5, 2.2, wall_units))
    objects.append(panel((2.75, -0.89), 1.0, 0.02, np.pi / 2, 1.2, 1.9, pictures[3]))
    # Ceiling lights (on by day, "all house lights on"; off at night).
    objects.append(Cylinder((1.5, 1.5), 0.22, 2.38, 2.5, shade, emission="ceiling_west"))
    objects.append(Cylinder((4.5, 1.5), 0.22, 2.38, 2.5, shade, emission="ceiling_east"))

    lights = {
        "ceiling_west": LightSource((1.5, 1.5, 2.35), (0.9, 0.85, 0.75), ("day",), glow=6.0),
        "ceiling_east": LightSource((4.5, 1.5, 2.35), (0.9, 0.85, 0.75), ("day",), glow=6.0),
        "floor_lamp": LightSource((4.6, 3.6, 1.55), (0.30, 0.22, 0.12), ("night",), glow=25.0),
        "table_lamp": LightSource((-0.75, 2.25, 0.85), (0.18, 0.13, 0.07), ("night",), glow=25.0),
        "oven": LightSource((5.75, -0.25, 0.45), (0.10, 0.08, 0.04), ("night",), glow=0.6),
    }
    return World("living_room", objects, tex, _room_floor(rng), (0.0, 0.0, 6.0, 3.0), True, 0.3, lights, seed)


_BUILDERS = {"garden": _garden, "living_room": _living_room, "large_garden": large_garden}


def build_world(name: str, seed: int = 0) -> World:
    """The world ``name`` (one of :data:`ALL_WORLDS`) with textures drawn from ``seed``.

    Worlds are cached (the last few built are reused); treat them as read-only.
    """
    if name not in _BUILDERS:
        raise ValueError(f"unknown world {name!r}; choose one of {', '.join(ALL_WORLDS)}")
    return _cached_world(name, int(seed))


@functools.lru_cache(maxsize=4)
def _cached_world(name: str, seed: int) -> World:
    return _BUILDERS[name](seed)
