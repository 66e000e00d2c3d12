"""Long synthetic routes for route mode: a street walked by day and again at night beside it.

The garden and the living room are a few metres across; route mode needs a route hundreds of
metres long, and viewpoint tolerance needs the night drive a few metres to the side of the day
one, as a robot (or a person) never repeats its path. :func:`build_street` lays out a straight
street ``length`` metres long: a paved path along ``y = 0`` (``|y| < 2.5``), plots on both sides
with fences, hedges and low walls at the front, houses set back 7-14 m with windows that glow at
night, trees, parked cars, street lamps every 16-24 m, and tall trees far behind. The seed draws
the layout, sizes, colours and textures.

:class:`RouteScene` renders it by day and night (the worlds' own lighting and sensor models);
:func:`street_drive` plans one walk along it (the day one on the right of the path, the night one
``offset`` metres to its left, with jitter along the route, sideways and in heading), and
:func:`render_drive` renders a walk for a panoramic camera or a forward one (a 90 x 45 degree
crop around the heading). A walk's vertical viewpoint is its own too: the camera's height above the
ground (a person's hand, a robot's mast), a pitch offset (the camera tilted up or down) and a pitch
wobble, per frame (a bumpy robot) or slow along the route (a camera carried by hand). Frame ``i``
of every drive is at the same distance along the street (plus the jitter), so the ground truth of
a pair is frame correspondence::

    from nightloc.synth.routes import RouteScene, build_street, street_drive, render_drive
    scene = RouteScene(build_street(seed=0), seed=0)
    day = render_drive(scene, street_drive(scene.world, "day", offset=0.0, seed=0), "forward")
    night = render_drive(scene, street_drive(scene.world, "night", offset=2.0, seed=1), "forward")
    lower = street_drive(scene.world, "night", offset=1.0, seed=2, height=1.1, pitch=-3.0, pitch_wobble=1.0)
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .dataset import DAY_GAMMA, DEFAULT_DARKNESS, NIGHT_GAMMA
from .geometry import Cylinder, Solid, box, panel
from .lighting import Lighting, make_lighting
from .render import Camera, render_radiance
from .sensor import Exposure, capture, metered_exposure
from .textures import TextureLibrary, fbm, jitter_colour, value_noise
from .world import GroundMap, LightSource, World

__all__ = [
    "CAMERAS",
    "FORWARD_CAMERA",
    "PANORAMIC_CAMERA",
    "Drive",
    "RouteScene",
    "build_street",
    "render_drive",
    "street_drive",
]

#: Height of the camera above the ground (a person walking, or a tall robot), metres.
CAMERA_HEIGHT = 1.4
#: The paved path: |y| below this, metres.
PATH_HALF_WIDTH = 2.5
#: Where the day walk keeps: the right-hand side of the path (y < 0 when walking towards +x).
DAY_LANE = -1.2

#: The panoramic camera (192 x 96, 80 degrees of elevation) and the forward camera's render (a
#: 384-column panorama whose 96 central columns, 90 degrees, make a forward image 45 degrees tall).
PANORAMIC_CAMERA = Camera(width=192, height=96, elevation_top_deg=50.0, elevation_bottom_deg=-30.0)
FORWARD_CAMERA = Camera(width=384, height=96, elevation_top_deg=25.0, elevation_bottom_deg=-20.0, oversample_y=1)
CAMERAS = ("forward", "panoramic")


def _street_ground(rng: np.random.Generator, length: float) -> GroundMap:
    ppm = 10.0
    x0, y0, x1, y1 = -40.0, -40.0, length + 40.0, 40.0
    rows, cols = int((y1 - y0) * ppm), int((x1 - x0) * ppm)
    xs, ys = np.meshgrid(x0 + (np.arange(cols) + 0.5) / ppm, y0 + (np.arange(rows) + 0.5) / ppm)
    blotch = fbm(rng, rows, cols, max(4, rows // 40), max(4, cols // 40), octaves=4)
    fine = value_noise(rng, rows, cols, rows // 3, cols // 3)
    grass_dark, grass_light = np.array([0.05, 0.15, 0.03], np.float32), np.array([0.14, 0.29, 0.07], np.float32)
    albedo = grass_dark + (grass_light - grass_dark) * np.clip(0.7 * blotch + 0.5 * fine - 0.1, 0, 1)[..., None]
    # Paving slabs of 0.8 m with joints along the path, and kerbs.
    slab = np.floor(xs / 0.8) * 7 + np.floor((ys + PATH_HALF_WIDTH) / 0.8) * 13
    tint = 0.78 + 0.4 * rng.random(97)[(slab % 97).astype(int)]
    paving = np.array([0.36, 0.35, 0.33], np.float32) * tint[..., None] * (0.9 + 0.2 * fine)[..., None]
    joint = ((xs % 0.8) < 0.03) | (((ys + PATH_HALF_WIDTH) % 0.8) < 0.03)
    paving[joint] *= 0.45
    path = np.abs(ys) < PATH_HALF_WIDTH
    albedo = np.where(path[..., None], paving, albedo)
    kerb = (np.abs(ys) >= PATH_HALF_WIDTH) & (np.abs(ys) < PATH_HALF_WIDTH + 0.2)
    albedo = np.where(kerb[..., None], np.array([0.55, 0.54, 0.5], np.float32), albedo)
    # Gravel drives to some plots.
    for x in rng.uniform(0.0, length, int(length / 25)):
        side = 1.0 if rng.random() < 0.5 else -1.0
        drive = (np.abs(xs - x) < 1.4) & (side * ys > PATH_HALF_WIDTH + 0.2) & (side * ys < 9.0)
        albedo = np.where(
            drive[..., None], np.array([0.32, 0.29, 0.25], np.float32) * (0.8 + 0.4 * fine)[..., None], albedo
        )
    return GroundMap(np.ascontiguousarray(albedo, dtype=np.float32), x0, y0, ppm)


def path_length(seed: int, length: float) -> float:
    """Checks a path world's ``seed`` (an int >= 0) and ``length`` (40 .. 2000 metres); returns the
    length as a float. ValueError names the argument."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an int >= 0, got {seed!r}")
    if not 40.0 <= float(length) <= 2000.0:
        raise ValueError(f"length must be 40 .. 2000 metres, got {length!r}")
    return float(length)


# long: a world builder: the list of the street's materials and objects, one after the other
def build_street(seed: int = 0, length: float = 250.0) -> World:
    """The street world (see the module docstring): ``length`` metres of path along +x."""
    length = path_length(seed, length)
    rng = np.random.default_rng([int(seed), 19])
    material = TextureLibrary(rng, ppm=60.0)
    tex = material.textures

    walls = [
        material("brick_a", "brick", 4.0, 3.0),
        material("brick_b", "brick", 4.0, 3.0, colour=jitter_colour(rng, (0.55, 0.30, 0.18))),
        material(
            "siding_a",
            "planks",
            4.0,
            3.0,
            colour=jitter_colour(rng, (0.75, 0.72, 0.62)),
            plank=0.15,
            gap=0.01,
            rails=(),
            vertical=False,
        ),
        material(
            "siding_b",
            "planks",
            4.0,
            3.0,
            colour=jitter_colour(rng, (0.25, 0.33, 0.42)),
            plank=0.12,
            gap=0.01,
            rails=(),
            vertical=False,
        ),
        material("render", "plain", 3.0, 3.0, colour=jitter_colour(rng, (0.82, 0.78, 0.66)), noise=0.25),
    ]
    roofs = [material("roof_a", "tiles", 4.0, 1.0), material("roof_b", "tiles", 4.0, 1.0, colour=(0.18, 0.18, 0.2))]
    fences = [
        material("fence_a", "planks", 4.0, 1.8, colour=jitter_colour(rng, (0.33, 0.20, 0.11))),
        material("fence_b", "planks", 4.0, 1.8, colour=jitter_colour(rng, (0.62, 0.60, 0.55)), plank=0.09),
    ]
    low_wall = material("low_wall", "brick", 4.0, 1.0, colour=jitter_colour(rng, (0.50, 0.45, 0.40)))
    hedges = [
        material(
            f"hedge_{i}",
            "foliage",
            3.0,
            2.0,
            dark=jitter_colour(rng, (0.03, 0.09, 0.02), 0.2),
            light=jitter_colour(rng, (0.15, 0.32, 0.07), 0.2),
            flowers=f,
            flower=fc,
        )
        for i, (f, fc) in enumerate([(0.0, (1, 1, 1)), (0.2, (0.85, 0.2, 0.3)), (0.15, (0.9, 0.85, 0.2))])
    ]
    canopies = [
        material(
            f"canopy_{i}", "foliage", 3.0, 2.0, dark=jitter_colour(rng, d, 0.2), light=jitter_colour(rng, lit, 0.2)
        )
        for i, (d, lit) in enumerate(
            [
                ((0.03, 0.10, 0.02), (0.16, 0.36, 0.07)),
                ((0.05, 0.08, 0.02), (0.26, 0.30, 0.08)),
                ((0.02, 0.07, 0.04), (0.10, 0.26, 0.12)),
            ]
        )
    ]
    bark = material("bark", "bark", 1.0, 2.0)
    metal = material("metal", "plain", 0.5, 1.0, colour=(0.15, 0.15, 0.16))
    lamp_glass = material("lamp", "plain", 0.5, 0.3, colour=(0.9, 0.85, 0.7), noise=0.05)
    doors = [
        material(f"door_{i}", "panels", 0.9, 2.0, colour=jitter_colour(rng, c))
        for i, c in enumerate([(0.08, 0.18, 0.35), (0.45, 0.10, 0.08), (0.15, 0.30, 0.15)])
    ]
    windows = [material(f"window_{i}", "window", 1.2, 1.2, panes=p) for i, p in enumerate([(2, 2), (3, 2), (2, 1)])]
    car_colours = [
        material(f"car_{i}", "plain", 4.0, 1.5, colour=jitter_colour(rng, c, 0.1), noise=0.05)
        for i, c in enumerate([(0.6, 0.05, 0.05), (0.1, 0.12, 0.35), (0.7, 0.7, 0.72), (0.05, 0.05, 0.06)])
    ]

    objects: list[Solid] = []
    lights: dict[str, LightSource] = {
        # Lit windows glow at night; the source itself is weak and far above.
        "windows": LightSource((length / 2, 0.0, 60.0), (0.01, 0.008, 0.005), ("night",), glow=0.3),
    }
    for side in (-1.0, 1.0):
        x = -30.0
        while x < length + 30.0:
            plot = float(rng.uniform(8.0, 16.0))
            x_mid = x + plot / 2

            def across(y0: float, y1: float, s: float = side) -> tuple[float, float]:
                """The y range [y0, y1] metres from the path's centre on this side, ordered."""
                a, b = s * y0, s * y1
                return (min(a, b), max(a, b))

            # Front boundary: fence, hedge, low wall or open.
            front = rng.choice(["fence", "hedge", "wall", "open"], p=[0.35, 0.3, 0.2, 0.15])
            gate = float(rng.uniform(1.0, 2.5))
            for a, b in ((x + 0.2, x_mid - gate / 2), (x_mid + gate / 2, x + plot - 0.2)):
                if b - a < 0.5:
                    continue
                if front == "fence":
                    y0, y1 = across(4.0, 4.08)
                    objects.append(
                        box(
                            a,
                            y0,
                            b,
                            y1,
                            0.0,
                            float(rng.uniform(1.0, 1.8)),
                            str(rng.choice(fences)),
                            u_offset=float(rng.uniform(0, 4)),
                        )
                    )
                elif front == "hedge":
                    y0, y1 = across(3.8, float(rng.uniform(4.5, 5.2)))
                    objects.append(
                        box(
                            a,
                            y0,
                            b,
                            y1,
                            0.0,
                            float(rng.uniform(0.9, 2.0)),
                            str(rng.choice(hedges)),
                            u_offset=float(rng.uniform(0, 3)),
                        )
                    )
                elif front == "wall":
                    y0, y1 = across(4.0, 4.3)
                    objects.append(
                        box(
                            a, y0, b, y1, 0.0, float(rng.uniform(0.6, 1.0)), low_wall, u_offset=float(rng.uniform(0, 4))
                        )
                    )
            # The house, set back, facing the street.
            if rng.random() < 0.85:
                depth = float(rng.uniform(7.0, 10.0))
                setback = float(rng.uniform(7.0, 14.0))
                width = plot - float(rng.uniform(1.5, 4.0))
                hx0 = x + (plot - width) / 2
                y0, y1 = across(setback, setback + depth)
                wall_height = float(rng.choice([3.0, 5.6, 6.0]))
                wall = str(rng.choice(walls))
                objects.append(box(hx0, y0, hx0 + width, y1, 0.0, wall_height, wall, u_offset=float(rng.uniform(0, 4))))
                objects.append(
                    box(
                        hx0 - 0.3,
                        y0 - 0.3,
                        hx0 + width + 0.3,
                        y1 + 0.3,
                        wall_height,
                        wall_height + 0.3,
                        str(rng.choice(roofs)),
                    )
                )
                face_y = side * setback - side * 0.01  # the street-facing wall, just in front of it
                facing = -np.pi / 2 if side > 0 else np.pi / 2
                door_x = hx0 + float(rng.uniform(1.0, width - 1.0))
                objects.append(panel((door_x, face_y), 0.9, 0.02, facing, 0.0, 2.0, str(rng.choice(doors))))
                floors = 1 if wall_height < 4 else 2
                for floor in range(floors):
                    for wx in np.arange(hx0 + 1.2, hx0 + width - 0.8, float(rng.uniform(2.2, 3.2))):
                        if abs(wx - door_x) < 1.2 and floor == 0:
                            continue
                        lit = rng.random() < 0.4
                        objects.append(
                            panel(
                                (float(wx), face_y),
                                1.1,
                                0.02,
                                facing,
                                0.9 + 2.8 * floor,
                                2.1 + 2.8 * floor,
                                str(rng.choice(windows)),
                                emission="windows" if lit else None,
                            )
                        )
            # Trees in front gardens, parked cars on the verge.
            for _ in range(int(rng.integers(0, 3))):
                tx = float(rng.uniform(x + 1.0, x + plot - 1.0))
                ty = side * float(rng.uniform(5.5, 6.8))
                radius = float(rng.uniform(0.9, 2.2))
                objects.append(
                    Cylinder(
                        (tx, ty),
                        float(rng.uniform(0.1, 0.25)),
                        0.0,
                        float(rng.uniform(1.5, 2.5)),
                        bark,
                        u_offset=float(rng.uniform(0, 3)),
                    )
                )
                objects.append(
                    Cylinder(
                        (tx, ty),
                        radius,
                        float(rng.uniform(1.6, 2.6)),
                        float(rng.uniform(4.0, 8.0)),
                        str(rng.choice(canopies)),
                        u_offset=float(rng.uniform(0, 3)),
                    )
                )
            if rng.random() < 0.25:
                cx = float(rng.uniform(x + 2.5, x + plot - 2.5))
                y0, y1 = across(3.05, 3.35)
                objects.append(box(cx - 2.1, y0, cx + 2.1, y1, 0.15, 1.45, str(rng.choice(car_colours))))
            # Tall trees far behind.
            if rng.random() < 0.7:
                tx = float(rng.uniform(x, x + plot))
                ty = side * float(rng.uniform(20.0, 32.0))
                objects.append(Cylinder((tx, ty), 0.35, 0.0, 4.0, bark))
                objects.append(
                    Cylinder(
                        (tx, ty),
                        float(rng.uniform(2.5, 4.5)),
                        3.0,
                        float(rng.uniform(9.0, 16.0)),
                        str(rng.choice(canopies)),
                        u_offset=float(rng.uniform(0, 3)),
                    )
                )
            x += plot
    # Street lamps every 16-24 m, on alternating sides of the path.
    x, k, side = 5.0, 0, 1.0
    while x < length:
        y = side * (PATH_HALF_WIDTH + 0.5)
        objects.append(Cylinder((x, y), 0.07, 0.0, 4.6, metal))
        objects.append(Cylinder((x, y), 0.28, 4.6, 4.9, lamp_glass, emission=f"lamp_{k}"))
        lights[f"lamp_{k}"] = LightSource((x, y, 4.75), (2.0, 1.5, 0.8), ("night",), glow=40.0)
        x += float(rng.uniform(16.0, 24.0))
        k += 1
        side = -side
    world = World(
        "street",
        objects,
        tex,
        _street_ground(rng, length),
        (0.0, -PATH_HALF_WIDTH, length, PATH_HALF_WIDTH),
        False,
        CAMERA_HEIGHT,
        lights,
        int(seed),
    )
    return world


class RouteScene:
    """A street with its day and night lighting and metered exposures (as nightloc.synth.SynthScene).

    Args:
        world: a :func:`build_street` world.
        seed: the sun's direction and the sky.
        darkness: night darkness (0: night lighting exposed like day; 1: 100x fewer photons).
    """

    def __init__(self, world: World, seed: int = 0, darkness: float = DEFAULT_DARKNESS):
        self.world = world
        self.seed = int(seed)
        self.darkness = float(darkness)
        self.lighting: dict[str, Lighting] = {c: make_lighting(world, c, self.seed) for c in ("day", "night")}
        x0, y0, x1, y1 = world.mapped_area
        self.exposure: dict[str, Exposure] = {}
        for condition, darkness_c, gamma in (("day", 0.0, DAY_GAMMA), ("night", self.darkness, NIGHT_GAMMA)):
            radiance = render_radiance(
                world, self.lighting[condition], (x0 + x1) / 2, (y0 + y1) / 2, 0.0, FORWARD_CAMERA
            )
            metered = float(np.minimum(radiance, np.percentile(radiance, 98.0)).mean())
            self.exposure[condition] = metered_exposure(metered, darkness_c, gamma)


@dataclass(frozen=True)
class Drive:
    """One walk along the street: ``positions (N, 2)`` metres, ``headings (N,)`` radians,
    ``pitches (N,)`` degrees (the camera tilted up), ``heights (N,)`` metres (the camera above the
    ground), the ``condition`` (``"day"``/``"night"``), the lateral ``offset`` from the day lane
    (metres, +y to the left) and the ``seed`` of its jitter and sensor noise."""

    positions: np.ndarray
    headings: np.ndarray
    pitches: np.ndarray
    condition: str
    offset: float
    seed: int
    heights: np.ndarray | None = None


#: Correlation length of :func:`street_drive`'s slow pitch wobble by default, metres along the route
#: (a few strides of a person carrying the camera).
WOBBLE_LENGTH = 4.0
#: Camera heights :func:`street_drive` accepts, metres (the street's lowest fence tops are 0.6 m).
HEIGHT_RANGE = (0.2, 3.0)


def _slow_wobble(rng: np.random.Generator, distances: np.ndarray, std: float, length: float) -> np.ndarray:
    """A smooth random process along the route, ``(N,)``: white noise on a 0.1 m grid smoothed by a
    Gaussian of ``length`` metres (standard deviation), scaled to a standard deviation of ``std``
    over the grid and read at ``distances`` (metres)."""
    step = 0.1
    sigma = length / step
    pad = int(np.ceil(4 * sigma))
    grid = np.arange(distances.min() - pad * step, distances.max() + (pad + 1) * step, step)
    white = rng.normal(0.0, 1.0, grid.size + 2 * pad)
    taps = np.exp(-0.5 * (np.arange(-pad, pad + 1) / sigma) ** 2)
    smooth = np.convolve(white, taps, mode="valid")[: grid.size]
    smooth = (smooth - smooth.mean()) / smooth.std()
    return std * np.interp(distances, grid, smooth)


def street_drive(
    world: World,
    condition: str,
    offset: float = 0.0,
    seed: int = 0,
    spacing: float = 0.8,
    jitter: float = 0.25,
    pitch: float = 0.0,
    pitch_jitter: float = 0.0,
    height: float | None = None,
    pitch_wobble: float = 0.0,
    wobble_length: float = WOBBLE_LENGTH,
) -> Drive:
    """A walk along the street ``offset`` metres left of the day lane, a frame every ``spacing``
    metres from x = 10 to length - 10: frame ``i`` at ``10 + i * spacing`` plus a uniform jitter of
    +-``jitter * spacing``, with a sideways wobble of 0.05 m and a heading wobble of 1.5 degrees
    (standard deviations), all drawn from ``seed``. The vertical viewpoint:

    * ``height``: the camera's height above the ground, metres (None: the street's
      ``camera_height``, 1.4 m; 0.2 .. 3.0);
    * ``pitch``: the camera tilted up by this many degrees (negative: down) on every frame;
    * ``pitch_jitter``: plus an independent wobble per frame, degrees (standard deviation; a
      bumpy robot);
    * ``pitch_wobble``: plus a slow wobble, degrees (standard deviation), smooth along the route
      over ``wobble_length`` metres (a Gaussian's standard deviation; a camera carried by hand).
    """
    if condition not in ("day", "night"):
        raise ValueError(f"condition must be 'day' or 'night', got {condition!r}")
    y = DAY_LANE + float(offset)
    if not -PATH_HALF_WIDTH < y < PATH_HALF_WIDTH + 0.3:
        raise ValueError(f"an offset of {offset} m leaves the path (the day lane is at y = {DAY_LANE})")
    camera_height = world.camera_height if height is None else float(height)
    if not HEIGHT_RANGE[0] <= camera_height <= HEIGHT_RANGE[1]:
        raise ValueError(
            f"height must be {HEIGHT_RANGE[0]} .. {HEIGHT_RANGE[1]} metres above the ground, got {height!r}"
        )
    for name, value in (("pitch_jitter", pitch_jitter), ("pitch_wobble", pitch_wobble)):
        if not 0.0 <= float(value) <= 10.0:
            raise ValueError(f"{name} must be 0 .. 10 degrees (a standard deviation), got {value!r}")
    if abs(float(pitch)) + 3 * (float(pitch_jitter) + float(pitch_wobble)) > 20.0:
        raise ValueError(
            f"pitch {pitch} deg with a wobble of {pitch_jitter} + {pitch_wobble} deg tilts the camera beyond 20 "
            f"degrees: the renderer's tilt moves the image rows, a fair model of small tilts only"
        )
    if not float(wobble_length) > 0.0:
        raise ValueError(f"wobble_length must be > 0 metres, got {wobble_length!r}")
    rng = np.random.default_rng([int(seed), 23])
    length = world.mapped_area[2]
    n = int((length - 20.0) / spacing) + 1
    xs = 10.0 + spacing * np.arange(n) + rng.uniform(-jitter, jitter, n) * spacing
    ys = y + rng.normal(0.0, 0.05, n)
    headings = rng.normal(0.0, np.radians(1.5), n)
    pitches = float(pitch) + (rng.normal(0.0, float(pitch_jitter), n) if pitch_jitter > 0 else np.zeros(n))
    if pitch_wobble > 0:
        pitches = pitches + _slow_wobble(
            np.random.default_rng([int(seed), 31]), xs, float(pitch_wobble), float(wobble_length)
        )
    positions = np.stack([xs, ys], axis=1)
    world.check_camera_positions(positions)
    heights = np.full(n, camera_height)
    return Drive(positions, headings, pitches, condition, float(offset), int(seed), heights)


def render_drive(scene: RouteScene, drive: Drive, camera: str = "forward", lens: Camera | None = None) -> np.ndarray:
    """The frames of a walk, ``(N, H, W, 3)`` uint8 BGR: panoramas (192 x 96, column 0 along the
    heading) or forward images (96 x 96: 90 degrees wide, from 25 degrees up to 20 down, the
    central quarter of FORWARD_CAMERA's columns), from the drive's camera heights and pitches.
    ``lens`` renders at another size (a forward image is the central quarter of its columns)."""
    if camera not in CAMERAS:
        raise ValueError(f"camera must be one of {CAMERAS}, got {camera!r}")
    base = lens if lens is not None else FORWARD_CAMERA if camera == "forward" else PANORAMIC_CAMERA
    heights = drive.heights if drive.heights is not None else np.full(len(drive.positions), scene.world.camera_height)
    frames = []
    for i, ((x, y), heading, pitch, height) in enumerate(zip(drive.positions, drive.headings, drive.pitches, heights)):
        rng = np.random.default_rng([drive.seed, 29, 0 if drive.condition == "day" else 1, i])
        # A small tilt moves the image up or down: the elevation range, shifted.
        lens = replace(
            base,
            elevation_top_deg=base.elevation_top_deg + float(pitch),
            elevation_bottom_deg=base.elevation_bottom_deg + float(pitch),
        )
        radiance = render_radiance(
            scene.world, scene.lighting[drive.condition], float(x), float(y), float(heading), lens, float(height)
        )
        image = capture(radiance, scene.exposure[drive.condition], rng)
        if camera == "forward":  # columns -45 .. +45 degrees around the heading, left to right
            columns = base.width // 4
            image = np.roll(image, columns // 2, axis=1)[:, :columns]
        frames.append(image)
    return np.stack(frames)
