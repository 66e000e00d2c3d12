"""The large garden: a 25 x 15 m lawn where odometry drift matters.

Fences round the lawn with posts, a house with windows and a porch lamp on the north side, a
shed, hedges, shrubs along the fences, a few trees and a birdbath on the lawn (placed between
the mowing rows, so every drive of :mod:`nightloc.synth.paths` passes them), trees beyond the
fences. Rendered on demand (``nightloc synth --world large_garden``); it is not part of the
default dataset.
"""

from __future__ import annotations

import numpy as np

from .geometry import Cylinder, Solid, box, panel
from .scene import GroundMap, LightSource, World
from .textures import TextureLibrary, fbm, jitter_colour, value_noise

__all__ = ["LARGE_GARDEN_AREA", "large_garden"]

#: The mapped area (x0, y0, x1, y1), metres.
LARGE_GARDEN_AREA = (0.0, 0.0, 25.0, 15.0)
_FENCE = (-1.5, -1.5, 26.5, 16.5)


def _ground(rng: np.random.Generator) -> GroundMap:
    ppm = 25.0
    x0, y0, x1, y1 = _FENCE
    rows, cols = int((y1 - y0) * ppm), int((x1 - x0) * ppm)
    xs, ys = np.meshgrid(x0 + (np.arange(cols) + 0.5) / ppm, y0 + (np.arange(rows) + 0.5) / ppm)
    blotch = fbm(rng, rows, cols, 16, 24, octaves=4)
    fine = value_noise(rng, rows, cols, rows // 2, cols // 2)
    dark, light = np.array([0.05, 0.16, 0.03], np.float32), np.array([0.13, 0.30, 0.06], np.float32)
    albedo = dark + (light - dark) * np.clip(0.7 * blotch + 0.5 * fine - 0.1, 0, 1)[..., None]
    mowing = np.where((np.floor((ys - y0) / 0.55) % 2) == 0, 1.12, 0.88)  # mowing stripes along x
    albedo *= mowing[..., None]
    worn = fbm(rng, rows, cols, 10, 14, octaves=3)
    albedo = np.where((worn > 0.72)[..., None], albedo * 0.5 + np.array([0.17, 0.13, 0.07], np.float32) * 0.6, albedo)
    soil = np.array([0.11, 0.07, 0.04], np.float32) * (0.7 + 0.6 * fine)[..., None]
    beds = (xs < -0.8) | (xs > 25.8) | (ys < -0.8)
    for cx, cy, r in ((6.0, 5.0, 0.9), (18.0, 10.0, 1.0), (20.5, 3.0, 0.7)):
        beds |= (xs - cx) ** 2 + (ys - cy) ** 2 < r**2
    albedo = np.where(beds[..., None], soil, albedo)
    patio = ys > 15.6
    paving = np.array([0.45, 0.42, 0.38], np.float32) * (0.85 + 0.3 * fine)[..., None]
    albedo = np.where(patio[..., None], paving, albedo)
    lawn = ~beds & ~patio
    stripes = np.where(lawn, mowing, 1.0).astype(np.float32)
    return GroundMap(np.ascontiguousarray(albedo, dtype=np.float32), x0, y0, ppm, lawn, stripes)


# long: a world builder: the list of the large garden's materials and objects, one after the other
def large_garden(seed: int) -> World:
    """The large garden world with textures drawn from ``seed`` (the layout is fixed)."""
    rng = np.random.default_rng([seed, 3])
    layout = np.random.default_rng(2020)  # the layout is the same for every seed
    material = TextureLibrary(rng, ppm=60.0)
    tex = material.textures

    fences = [
        material(f"fence_{i}", "planks", 4.0, 1.8, colour=jitter_colour(rng, c), plank=p)
        for i, (c, p) in enumerate(
            [((0.33, 0.20, 0.11), 0.1), ((0.42, 0.30, 0.18), 0.15), ((0.28, 0.22, 0.16), 0.12), ((0.5, 0.36, 0.2), 0.2)]
        )
    ]
    post = material("post", "wood", 0.5, 2.0, colour=(0.22, 0.14, 0.08))
    brick = material("brick", "brick", 6.0, 3.2)
    roof = material("roof", "tiles", 6.0, 1.0)
    siding = material(
        "shed", "planks", 4.0, 2.1, colour=(0.20, 0.30, 0.22), plank=0.12, gap=0.01, rails=(), vertical=False
    )
    door = material("door", "panels", 0.9, 2.0, colour=(0.08, 0.18, 0.35))
    bark = material("bark", "bark", 1.0, 2.0)
    stone = material("stone", "plain", 1.0, 1.0, colour=(0.45, 0.43, 0.40), noise=0.4)
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

    x0, y0, x1, y1 = _FENCE
    objects: list[Solid] = []
    # Fences in 7 m sections of different boards; posts every 2.5 m; the house closes the north.
    for k, xa in enumerate(np.arange(x0, x1, 7.0)):
        objects.append(box(xa, y0 - 0.06, min(xa + 7.0, x1), y0, 0.0, 1.8, fences[k % 4], u_offset=float(k)))
    for k, ya in enumerate(np.arange(y0, y1, 6.0)):
        top = min(ya + 6.0, y1)
        objects.append(box(x0 - 0.06, ya, x0, top, 0.0, 1.8 - 0.2 * (k % 2), fences[(k + 1) % 4]))
        objects.append(box(x1, ya, x1 + 0.06, top, 0.0, 1.6 + 0.2 * (k % 2), fences[(k + 2) % 4]))
    for x in np.arange(x0 + 2.5, x1, 2.5):
        objects.append(box(x - 0.05, y0, x + 0.05, y0 + 0.08, 0.0, 1.95, post))
    for y in np.arange(y0 + 2.5, y1, 2.5):
        objects.append(box(x0, y - 0.05, x0 + 0.08, y + 0.05, 0.0, 1.95, post))
        objects.append(box(x1 - 0.08, y - 0.05, x1, y + 0.05, 0.0, 1.75, post))
    objects.append(box(x0, y1, x1, y1 + 3.0, 0.0, 3.4, brick))
    objects.append(box(x0 - 0.3, y1 - 0.25, x1 + 0.3, y1 + 3.3, 3.4, 3.65, roof))
    for i, (x, w) in enumerate([(1.5, 1.4), (5.0, 1.0), (9.0, 1.6), (15.5, 1.2), (20.0, 1.4), (24.0, 1.0)]):
        objects.append(
            panel(
                (x, y1 - 0.01),
                w,
                0.02,
                -np.pi / 2,
                0.9,
                2.1,
                windows[i % 3],
                emission="house_window" if i % 2 else None,
            )
        )
    objects.append(panel((12.0, y1 - 0.01), 0.9, 0.02, -np.pi / 2, 0.0, 2.0, door))
    objects.append(Cylinder((12.8, y1 - 0.08), 0.07, 2.05, 2.3, lamp, emission="porch_lamp"))
    # Shed in the south-east corner, a hedge along part of the east fence, a compost box west.
    objects.append(box(x1 - 1.1, y0 + 0.05, x1 - 0.05, y0 + 2.3, 0.0, 2.1, siding))
    objects.append(box(x1 - 0.75, 6.0, x1 - 0.05, 11.0, 0.0, 1.3, leaves[1]))
    objects.append(box(x0 + 0.05, 9.0, x0 + 0.9, 10.2, 0.0, 0.9, fences[3]))
    # Shrubs along the fences (sizes and leaves vary), away from the drives.
    for k in range(26):
        side = k % 3
        if side == 0:
            cx, cy = layout.uniform(0.5, 24.5), y0 + 0.55
        elif side == 1:
            cx, cy = x0 + 0.55, layout.uniform(0.5, 14.5)
        else:
            cx, cy = x1 - 0.55, layout.uniform(0.5, 5.5) if k % 2 else layout.uniform(11.5, 14.5)
        radius, height = layout.uniform(0.3, 0.5), layout.uniform(0.6, 1.5)
        objects.append(Cylinder((cx, cy), radius, 0.0, height, leaves[k % 6], u_offset=rng.uniform(0, 3)))
    # On the lawn, between the mowing rows (half-metre marks): trees, a birdbath, a bird feeder.
    for (cx, cy), trunk_r, canopy_r, canopy_z, leaf in [
        ((6.0, 5.0), 0.12, 1.0, (1.2, 3.6), leaves[0]),
        ((18.0, 10.0), 0.14, 1.3, (1.3, 4.2), leaves[5]),
    ]:
        objects.append(Cylinder((cx, cy), trunk_r, 0.0, canopy_z[0] + 0.5, bark, u_offset=rng.uniform(0, 3)))
        objects.append(Cylinder((cx, cy), canopy_r, canopy_z[0], canopy_z[1], leaf, u_offset=rng.uniform(0, 3)))
    objects.append(Cylinder((12.0, 8.0), 0.1, 0.0, 0.7, stone))
    objects.append(Cylinder((12.0, 8.0), 0.3, 0.7, 0.85, stone))
    objects.append(Cylinder((20.5, 3.0), 0.04, 0.0, 1.6, metal))
    objects.append(Cylinder((20.5, 3.0), 0.2, 1.6, 1.9, fences[1]))
    # Trees beyond the fences and a street lamp.
    for (cx, cy), r, top, leaf in [
        ((30.0, 4.0), 2.5, 8.0, leaves[1]),
        ((-5.0, 12.0), 2.2, 7.0, leaves[0]),
        ((8.0, -5.0), 2.8, 8.5, leaves[5]),
        ((21.0, -4.5), 2.0, 6.5, leaves[0]),
        ((-4.5, 1.0), 1.8, 6.0, leaves[5]),
    ]:
        objects.append(Cylinder((cx, cy), 0.3, 0.0, 3.0, bark, u_offset=rng.uniform(0, 3)))
        objects.append(Cylinder((cx, cy), r, 2.3, top, leaf, u_offset=rng.uniform(0, 3)))
    objects.append(Cylinder((-3.0, -4.0), 0.06, 0.0, 4.4, metal))
    objects.append(Cylinder((-3.0, -4.0), 0.25, 4.4, 4.65, lamp, emission="street_lamp"))
    lights = {
        "porch_lamp": LightSource((12.8, y1 - 0.3, 2.15), (0.9, 0.7, 0.4), ("night",), glow=40.0),
        "house_window": LightSource((12.0, y1 - 0.4, 1.6), (0.6, 0.45, 0.25), ("night",), glow=0.25),
        "street_lamp": LightSource((-3.0, -4.0, 4.35), (4.0, 3.0, 1.6), ("night",), glow=40.0),
    }
    return World("large_garden", objects, tex, _ground(rng), LARGE_GARDEN_AREA, False, 0.3, lights, seed)
