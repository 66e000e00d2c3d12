"""Procedural textures: tileable noise, stripes, bricks, planks, foliage, pictures...

Every texture is a :class:`Texture`: a ``(rows, cols, 3)`` uint8 array of *linear* RGB albedo
(``value / 255``) and its resolution in pixels per metre. Textures tile: ``u`` wraps around the
columns and ``v`` around the rows. Nothing is downloaded; every pattern comes from a seeded
``numpy.random.Generator``, so the same seed gives the same textures.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["TEXTURE_KINDS", "Texture", "fbm", "make_texture", "value_noise"]

RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Texture:
    """Albedo image ``(rows, cols, 3)`` uint8 (linear RGB x 255), ``pixels_per_metre`` on both axes.

    ``emissive`` (same shape, or None for "same as albedo") is the pattern a glowing object shows
    when its light is on: the glass of a lit window, an oven's door window.
    """

    albedo: np.ndarray
    pixels_per_metre: float
    emissive: np.ndarray | None = None


def value_noise(rng: np.random.Generator, rows: int, cols: int, cells_y: int, cells_x: int) -> np.ndarray:
    """Smooth tileable noise in about [0, 1], ``(rows, cols)`` float32.

    A ``cells_y x cells_x`` grid of uniform random values, padded cyclically and interpolated
    bicubically; the result wraps seamlessly in both directions.
    """
    cells_y, cells_x = max(1, int(cells_y)), max(1, int(cells_x))
    grid = rng.random((cells_y, cells_x)).astype(np.float32)
    pad = 2
    padded = np.pad(grid, pad, mode="wrap")
    step_y, step_x = rows / cells_y, cols / cells_x
    big = cv2.resize(
        padded,
        (int(round(step_x * (cells_x + 2 * pad))), int(round(step_y * (cells_y + 2 * pad)))),
        interpolation=cv2.INTER_CUBIC,
    )
    y0, x0 = int(round(step_y * pad)), int(round(step_x * pad))
    return np.ascontiguousarray(big[y0 : y0 + rows, x0 : x0 + cols])


def fbm(
    rng: np.random.Generator, rows: int, cols: int, cells_y: int, cells_x: int, octaves: int = 4, gain: float = 0.5
) -> np.ndarray:
    """Fractal sum of :func:`value_noise` octaves, rescaled to [0, 1], ``(rows, cols)`` float32."""
    total = np.zeros((rows, cols), np.float32)
    amplitude = 1.0
    for octave in range(octaves):
        scale = 2**octave
        if cells_y * scale > rows or cells_x * scale > cols:
            break
        total += amplitude * value_noise(rng, rows, cols, cells_y * scale, cells_x * scale)
        amplitude *= gain
    low, high = float(total.min()), float(total.max())
    return (total - low) / max(high - low, 1e-6)


def _mix(a: RGB, b: RGB, t: np.ndarray) -> np.ndarray:
    """Per-pixel blend of colours a and b by t in [0, 1]: ``(..., 3)``."""
    a_arr, b_arr = np.asarray(a, np.float32), np.asarray(b, np.float32)
    return a_arr + (b_arr - a_arr) * t[..., None]


def _to_uint8(values: np.ndarray) -> np.ndarray:
    return np.clip(np.round(np.asarray(values, np.float32) * 255.0), 0, 255).astype(np.uint8)


def _shape(width_m: float, height_m: float, ppm: float) -> tuple[int, int]:
    return max(4, int(round(height_m * ppm))), max(4, int(round(width_m * ppm)))


def _jitter(rng: np.random.Generator, colour: RGB, amount: float) -> np.ndarray:
    return np.clip(np.asarray(colour) * (1.0 + amount * rng.uniform(-1, 1, 3)), 0.0, 1.0)


# --- texture kinds -----------------------------------------------------------------------------


def _planks(rng, rows, cols, ppm, colour=(0.35, 0.22, 0.12), plank=0.1, gap=0.012, rails=(0.3, 1.4), vertical=True):
    """Fence / cladding boards: per-board tint, wood grain, dark gaps, horizontal rails."""
    grain = fbm(rng, rows, cols, max(1, rows // 32), max(1, cols // 4), octaves=3)
    albedo = _mix(np.multiply(colour, 0.75), np.multiply(colour, 1.2), grain)
    along = np.arange(cols if vertical else rows) / ppm
    board = np.floor(along / plank).astype(int)
    tint = 0.75 + 0.5 * rng.random(board.max() + 1)
    in_gap = (along % plank) < gap
    shade = np.where(in_gap, 0.25, tint[board])
    albedo *= (shade[None, :] if vertical else shade[:, None])[..., None]
    for rail in rails:
        row = int(rail * ppm)
        albedo[max(0, row - int(0.04 * ppm)) : row + int(0.04 * ppm)] *= 0.7
    return albedo


def _brick(rng, rows, cols, ppm, colour=(0.45, 0.16, 0.09), mortar=(0.55, 0.52, 0.47)):
    """Running-bond brickwork with per-brick tint and mortar joints."""
    y = np.arange(rows)[:, None] / ppm
    x = np.arange(cols)[None, :] / ppm
    course = np.floor(y / 0.076).astype(int)
    shifted = x + (course % 2) * 0.1125
    brick = np.floor(shifted / 0.225).astype(int)
    ids = (course * 1009 + brick) % 4096
    tint = 0.65 + 0.6 * rng.random(4096)
    joint = ((y % 0.076) < 0.011) | ((shifted % 0.225) < 0.011)
    grit = fbm(rng, rows, cols, max(1, rows // 8), max(1, cols // 8), octaves=2)
    albedo = np.asarray(colour, np.float32) * (tint[ids] * (0.85 + 0.3 * grit))[..., None]
    albedo[joint] = np.asarray(mortar, np.float32) * (0.9 + 0.2 * grit[joint])[:, None]
    return albedo


def _foliage(
    rng, rows, cols, ppm, dark=(0.03, 0.10, 0.02), light=(0.16, 0.36, 0.07), flowers=0.0, flower=(0.8, 0.75, 0.2)
):
    """Leaves: blotchy two-tone noise with fine detail and optional flower dots."""
    coarse = fbm(rng, rows, cols, max(1, rows // 24), max(1, cols // 24), octaves=3)
    fine = value_noise(rng, rows, cols, max(1, rows // 3), max(1, cols // 3))
    t = np.clip(0.65 * coarse + 0.55 * fine - 0.1, 0, 1)
    albedo = _mix(dark, light, t)
    if flowers > 0:
        count = int(flowers * rows * cols / 40)
        ys, xs = rng.integers(0, rows, count), rng.integers(0, cols, count)
        for dy in (0, 1):
            for dx in (0, 1):
                albedo[(ys + dy) % rows, (xs + dx) % cols] = flower
    return albedo


def _bark(rng, rows, cols, ppm, colour=(0.20, 0.13, 0.08)):
    """Vertical fissured bark."""
    streaks = value_noise(rng, rows, cols, max(1, rows // 64), max(1, cols // 2))
    knots = fbm(rng, rows, cols, max(1, rows // 16), max(1, cols // 16), octaves=2)
    return np.asarray(colour, np.float32) * (0.45 + 0.7 * streaks * (0.6 + 0.4 * knots))[..., None]


def _paint(
    rng, rows, cols, ppm, colour=(0.70, 0.66, 0.58), stripes=0.0, stripe_colour=(0.55, 0.50, 0.42), skirting=0.0
):
    """Painted plaster or wallpaper: flat colour, faint mottling, optional vertical stripes and skirting board."""
    mottle = fbm(rng, rows, cols, max(1, rows // 32), max(1, cols // 32), octaves=3)
    albedo = np.asarray(colour, np.float32) * (0.92 + 0.16 * mottle)[..., None]
    if stripes > 0:
        x = np.arange(cols) / ppm
        band = (x % stripes) < stripes * 0.45
        albedo[:, band] = np.asarray(stripe_colour, np.float32) * (0.92 + 0.16 * mottle[:, band])[..., None]
    if skirting > 0:
        albedo[rows - int(skirting * ppm) :] = (0.85, 0.84, 0.80)
    return albedo


def _wood(rng, rows, cols, ppm, colour=(0.40, 0.24, 0.12)):
    """Furniture wood: horizontal grain."""
    grain = value_noise(rng, rows, cols, max(1, rows // 2), max(1, cols // 64))
    rings = fbm(rng, rows, cols, max(1, rows // 16), max(1, cols // 16), octaves=2)
    return np.asarray(colour, np.float32) * (0.7 + 0.45 * grain * (0.7 + 0.3 * rings))[..., None]


def _fabric(rng, rows, cols, ppm, colour=(0.15, 0.20, 0.40), seam=0.6):
    """Upholstery: weave noise, darker seams every ``seam`` metres and a darker base."""
    weave = value_noise(rng, rows, cols, max(1, rows // 2), max(1, cols // 2))
    folds = fbm(rng, rows, cols, max(1, rows // 24), max(1, cols // 24), octaves=2)
    albedo = np.asarray(colour, np.float32) * (0.75 + 0.15 * weave + 0.25 * folds)[..., None]
    x = np.arange(cols) / ppm
    albedo[:, (x % seam) < 0.015] *= 0.45
    albedo[rows - max(1, rows // 6) :] *= 0.6
    return albedo


def _books(rng, rows, cols, ppm, shelf=0.35, wood=(0.30, 0.18, 0.09)):
    """A bookcase front: shelves of books with random widths, heights and colours."""
    albedo = np.empty((rows, cols, 3), np.float32)
    albedo[:] = np.asarray(wood, np.float32) * 0.35
    palette = np.array(
        [
            [0.5, 0.05, 0.05],
            [0.05, 0.15, 0.45],
            [0.6, 0.5, 0.1],
            [0.1, 0.35, 0.1],
            [0.7, 0.7, 0.65],
            [0.08, 0.08, 0.08],
            [0.55, 0.25, 0.05],
        ],
        np.float32,
    )
    shelf_px = max(2, int(shelf * ppm))
    board = max(1, int(0.025 * ppm))
    for top in range(0, rows, shelf_px):
        albedo[top : top + board] = wood
        x = 0
        while x < cols:
            w = int(rng.uniform(0.015, 0.05) * ppm) + 1
            h = int(rng.uniform(0.6, 0.95) * (shelf_px - board))
            if rng.random() < 0.08:
                x += w * 2  # a gap
                continue
            colour = palette[rng.integers(len(palette))] * rng.uniform(0.6, 1.2)
            albedo[top + shelf_px - h : top + shelf_px, x : x + w] = colour
            x += w
    return albedo


def _picture(rng, rows, cols, ppm, frame=(0.1, 0.07, 0.04)):
    """A painting: gradient background, a few ellipses and rectangles, a frame."""
    top_colour, bottom_colour = rng.uniform(0.05, 0.8, 3), rng.uniform(0.05, 0.8, 3)
    albedo = _mix(
        tuple(top_colour), tuple(bottom_colour), np.linspace(0, 1, rows, dtype=np.float32)[:, None].repeat(cols, 1)
    )
    for _ in range(int(rng.integers(3, 7))):
        colour = tuple(float(c) for c in rng.uniform(0.02, 0.9, 3))
        cx, cy = int(rng.integers(0, cols)), int(rng.integers(0, rows))
        if rng.random() < 0.5:
            axes = (int(rng.integers(cols // 10 + 1, cols // 3 + 2)), int(rng.integers(rows // 10 + 1, rows // 3 + 2)))
            cv2.ellipse(albedo, (cx, cy), axes, float(rng.uniform(0, 180)), 0, 360, colour, -1)
        else:
            w, h = int(rng.integers(cols // 8 + 1, cols // 2 + 2)), int(rng.integers(rows // 8 + 1, rows // 2 + 2))
            cv2.rectangle(albedo, (cx - w // 2, cy - h // 2), (cx + w // 2, cy + h // 2), colour, -1)
    border = max(1, int(0.035 * ppm))
    albedo[:border], albedo[-border:], albedo[:, :border], albedo[:, -border:] = frame, frame, frame, frame
    return albedo


def _window(rng, rows, cols, ppm, glass=(0.10, 0.13, 0.16), frame=(0.75, 0.75, 0.72), panes=(2, 2)):
    """Glazing with a frame and mullions; the glass gets a faint reflection gradient."""
    reflection = fbm(rng, rows, cols, max(1, rows // 32), max(1, cols // 32), octaves=2)
    albedo = _mix(glass, tuple(np.multiply(glass, 1.8)), reflection)
    lit = _mix((1.0, 0.75, 0.45), (0.75, 0.5, 0.3), fbm(rng, rows, cols, 2, 2, octaves=2))  # room light behind
    bar = max(1, int(0.04 * ppm))
    for i in range(panes[0] + 1):
        x = min(cols - bar, int(i * (cols - bar) / panes[0]))
        albedo[:, x : x + bar] = frame
        lit[:, x : x + bar] = 0.0
    for j in range(panes[1] + 1):
        y = min(rows - bar, int(j * (rows - bar) / panes[1]))
        albedo[y : y + bar] = frame
        lit[y : y + bar] = 0.0
    return albedo, lit


def _screen(rng, rows, cols, ppm):
    """A television: black glass, thin dark frame, a small light-grey logo."""
    albedo = np.full((rows, cols, 3), 0.02, np.float32)
    albedo += 0.03 * fbm(rng, rows, cols, 2, 2, octaves=1)[..., None]
    border = max(1, int(0.02 * ppm))
    albedo[:border], albedo[-border:], albedo[:, :border], albedo[:, -border:] = 0.08, 0.08, 0.08, 0.08
    albedo[rows - border : rows, cols // 2 - border : cols // 2 + border] = 0.6
    return albedo


def _curtain(rng, rows, cols, ppm, colour=(0.55, 0.35, 0.25)):
    """Curtain folds: vertical sinusoidal shading with irregular spacing."""
    phase = np.cumsum(rng.uniform(0.6, 1.4, cols)) / ppm
    folds = 0.7 + 0.3 * np.sin(2 * np.pi * phase / 0.09)
    return np.asarray(colour, np.float32) * folds[None, :, None] * np.ones((rows, 1, 1), np.float32)


def _tiles(rng, rows, cols, ppm, colour=(0.30, 0.28, 0.27)):
    """Roof shingles: staggered rows with per-tile tint."""
    y = np.arange(rows)[:, None] / ppm
    x = np.arange(cols)[None, :] / ppm
    course = np.floor(y / 0.15).astype(int)
    tile = np.floor((x + (course % 2) * 0.1) / 0.2).astype(int)
    tint = 0.7 + 0.5 * rng.random(2048)
    albedo = np.asarray(colour, np.float32) * tint[(course * 97 + tile) % 2048][..., None]
    albedo[(y[:, 0] % 0.15) < 0.015] *= 0.4
    return albedo


def _panels(rng, rows, cols, ppm, colour=(0.55, 0.15, 0.10), handle=(0.8, 0.7, 0.3)):
    """A door or cabinet front: raised panels and a handle."""
    albedo = _wood(rng, rows, cols, ppm, colour)
    inset = max(1, int(0.08 * ppm))
    mid = rows // 2
    for y0, y1 in ((inset, mid - inset // 2), (mid + inset // 2, rows - inset)):
        albedo[y0 : y0 + 2, inset : cols - inset] *= 0.5
        albedo[y1 - 2 : y1, inset : cols - inset] *= 1.4
        albedo[y0:y1, inset : inset + 2] *= 0.5
        albedo[y0:y1, cols - inset - 2 : cols - inset] *= 1.4
    h = max(2, int(0.04 * ppm))
    albedo[mid - h : mid + h, cols - inset - 3 * h : cols - inset - h] = handle
    return albedo


def _appliance(rng, rows, cols, ppm, colour=(0.75, 0.75, 0.73)):
    """An oven / appliance front: enamel, a dark glass door window and a bar handle."""
    albedo = np.empty((rows, cols, 3), np.float32)
    albedo[:] = colour
    albedo *= (0.95 + 0.1 * fbm(rng, rows, cols, 2, 2, octaves=1))[..., None]
    m = max(1, int(0.06 * ppm))
    albedo[rows // 3 : rows - m, m : cols - m] = (0.06, 0.05, 0.05)
    albedo[rows // 3 - 2 * m : rows // 3 - m, 2 * m : cols - 2 * m] = (0.25, 0.25, 0.25)
    albedo[: rows // 5, :] *= 0.6
    lit = np.zeros_like(albedo)
    lit[rows // 3 + m : rows - 2 * m, 2 * m : cols - 2 * m] = (1.0, 0.7, 0.35)  # the oven light
    return albedo, lit


def _plain(rng, rows, cols, ppm, colour=(0.8, 0.78, 0.72), noise=0.1):
    """A nearly uniform surface (ceiling, lamp shade, shed roof underside)."""
    return (
        np.asarray(colour, np.float32)
        * (1 - noise / 2 + noise * fbm(rng, rows, cols, max(1, rows // 32), max(1, cols // 32), 3))[..., None]
    )


TEXTURE_KINDS: dict[str, Callable[..., np.ndarray]] = {
    "planks": _planks,
    "brick": _brick,
    "foliage": _foliage,
    "bark": _bark,
    "paint": _paint,
    "wood": _wood,
    "fabric": _fabric,
    "books": _books,
    "picture": _picture,
    "window": _window,
    "screen": _screen,
    "curtain": _curtain,
    "tiles": _tiles,
    "panels": _panels,
    "appliance": _appliance,
    "plain": _plain,
}


def make_texture(
    kind: str, rng: np.random.Generator, width_m: float, height_m: float, ppm: float = 100.0, **params
) -> Texture:
    """A ``width_m x height_m`` metre texture of one of :data:`TEXTURE_KINDS`.

    Args:
        kind: pattern name, e.g. ``"brick"``, ``"foliage"``, ``"picture"``.
        rng: source of randomness (same state -> same texture).
        width_m, height_m: the tile's size in metres (it repeats beyond).
        ppm: resolution in pixels per metre (100 = 1 cm pixels).
        params: pattern parameters (colours as linear RGB in [0, 1], sizes in metres).
    """
    if kind not in TEXTURE_KINDS:
        raise ValueError(f"unknown texture kind {kind!r}; choose one of {sorted(TEXTURE_KINDS)}")
    rows, cols = _shape(width_m, height_m, ppm)
    made = TEXTURE_KINDS[kind](rng, rows, cols, ppm, **params)
    albedo, emissive = made if isinstance(made, tuple) else (made, None)
    return Texture(_to_uint8(albedo), float(ppm), None if emissive is None else _to_uint8(emissive))


class TextureLibrary:
    """A world's textures by material name, each drawn from one generator in the order they are made.

    Calling it, ``library(name, kind, width, height, ppm=None, **params)``, makes the texture
    ``kind`` of ``width`` x ``height`` metres at ``ppm`` pixels per metre (default: the library's)
    with :func:`make_texture`, stores it under ``name`` in :attr:`textures` and returns ``name`` (the
    material of a solid).
    """

    def __init__(self, rng: np.random.Generator, ppm: float):
        self.rng = rng
        self.ppm = ppm
        self.textures: dict[str, Texture] = {}

    def __call__(self, name: str, kind: str, width: float, height: float, ppm: float | None = None, **params) -> str:
        self.textures[name] = make_texture(kind, self.rng, width, height, self.ppm if ppm is None else ppm, **params)
        return name


def jitter_colour(
    rng: np.random.Generator, colour: Sequence[float], amount: float = 0.15
) -> tuple[float, float, float]:
    """``colour`` with each channel scaled by a random factor in ``1 +- amount``."""
    red, green, blue = _jitter(rng, (float(colour[0]), float(colour[1]), float(colour[2])), amount)
    return float(red), float(green), float(blue)
