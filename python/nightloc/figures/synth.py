"""Figures of the synthetic worlds, drawn with OpenCV: day vs night panoramas, and maps.

    python -m nightloc.figures.synth docs/figures

writes ``synth_<world>_day_night.png`` (a day and a night panorama of the same pose, and both
prepared as the matcher sees them) and ``synth_<world>_map.png`` (the world from above, by day,
with the traverses: day reference red, night reference green, night query blue, as the paper's
Figures 4b and 5b).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from ..io.atomic import write_bytes
from ..preparation.preparer import prepare
from ..synth.dataset import DEFAULT_DARKNESS, DEFAULT_SEED, SynthScene
from ..synth.geometry import polygon_of
from ..synth.paths import plan_traverses

__all__ = ["FIGURE_POSES", "day_night_figure", "main", "map_figure"]

#: The pose (x, y, heading) shown in each world's day/night figure.
FIGURE_POSES = {"garden": (3.5, 2.5, -1.3), "living_room": (2.5, 1.2, np.pi / 2)}

_TRAVERSE_COLOURS = {"day_reference": (40, 40, 220), "night_reference": (40, 170, 40), "night_query": (220, 90, 30)}


def _label(image: np.ndarray, *lines: str) -> np.ndarray:
    """``image`` with a caption strip above it, 18 pixels per line."""
    strip = np.full((18 * len(lines) + 2, image.shape[1], 3), 255, np.uint8)
    for i, text in enumerate(lines):
        cv2.putText(strip, text, (4, 14 + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (0, 0, 0), 1, cv2.LINE_AA)
    return np.concatenate([strip, image])


def _zoom(image: np.ndarray, factor: int) -> np.ndarray:
    return cv2.resize(image, None, fx=factor, fy=factor, interpolation=cv2.INTER_NEAREST)


def day_night_figure(
    world: str = "garden",
    pose: tuple[float, float, float] | None = None,
    seed: int = DEFAULT_SEED,
    darkness: float = DEFAULT_DARKNESS,
    zoom: int = 2,
) -> np.ndarray:
    """A day and a night panorama (192 x 96) of the same pose and both prepared (48 x 24), BGR."""
    scene = SynthScene(world, seed, darkness)
    x, y, heading = pose if pose is not None else FIGURE_POSES[world]
    day = scene.frame("day", x, y, heading, scene.frame_rng("figure_day", 0))
    night = scene.frame("night", x, y, heading, scene.frame_rng("figure_night", 0))
    prepared = prepare(np.stack([day, night]))
    width = day.shape[1] * zoom
    small = [cv2.cvtColor(_zoom(p, width // (2 * p.shape[1])), cv2.COLOR_GRAY2BGR) for p in prepared]
    where = f"x={x:.1f} m, y={y:.1f} m, heading {np.degrees(heading):.0f} deg"
    parts = [
        _label(_zoom(day, zoom), f"{world}, day ({where})"),
        _label(
            _zoom(night, zoom), f"night, darkness {darkness:g}: mean grey {night.mean():.0f} vs {day.mean():.0f} by day"
        ),
        _label(np.concatenate(small, axis=1), "prepared 48x24 (equalized, patch-normalized): day | night"),
    ]
    return np.concatenate(parts)


def map_figure(world: str = "garden", seed: int = DEFAULT_SEED, pixels_per_metre: int = 36) -> np.ndarray:
    """The world from above: day-lit ground, object outlines, traverse positions and headings (BGR)."""
    scene = SynthScene(world, seed)
    ground = scene.lighting["day"].ground
    linear = ground.values / np.percentile(ground.values, 99.5)
    image = (255 * np.clip(linear, 0, 1) ** (1 / 2.2))[::-1, :, ::-1].astype(np.uint8)  # north up, BGR
    scale = pixels_per_metre / ground.pixels_per_metre
    image = np.ascontiguousarray(cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA))
    rows = image.shape[0]

    def to_pixels(points: np.ndarray) -> np.ndarray:
        px = (points[:, 0] - ground.x0) * pixels_per_metre
        py = rows - (points[:, 1] - ground.y0) * pixels_per_metre
        return np.round(np.stack([px, py], axis=1) * 16).astype(np.int32)

    for obj in scene.world.objects:
        if obj.top > 0.05 and obj.bottom < 2.6:
            cv2.polylines(image, [to_pixels(polygon_of(obj))], True, (255, 255, 255), 1, cv2.LINE_AA, shift=4)
    x0, y0, x1, y1 = scene.world.mapped_area
    cv2.rectangle(
        image, *[tuple(int(v) // 16 for v in p) for p in to_pixels(np.array([[x0, y1], [x1, y0]]))], (0, 255, 255), 1
    )
    for plan in plan_traverses(world, seed):
        colour = _TRAVERSE_COLOURS[plan.name]
        tips = plan.positions + 0.25 * np.stack([np.cos(plan.headings), np.sin(plan.headings)], axis=1)
        for start, end in zip(to_pixels(plan.positions), to_pixels(tips)):
            cv2.line(image, tuple(start), tuple(end), colour, 1, cv2.LINE_AA, shift=4)
            cv2.circle(image, tuple(start), 3 * 16, colour, -1, cv2.LINE_AA, shift=4)
    colours = {"day_reference": "red", "night_reference": "green", "night_query": "blue"}
    legend = ", ".join(f"{p.name.replace('_', ' ')} {colours[p.name]}" for p in plan_traverses(world, seed))
    return _label(image, f"{world} from above (yellow: mapped area)", legend)


def _save_png(path: Path, image: np.ndarray) -> None:
    ok, encoded = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    if not ok:
        raise ValueError(f"could not encode {path}")
    write_bytes(path, encoded.tobytes())


def main(argv: Sequence[str] | None = None) -> int:
    """Writes the figures of both worlds into the folder given as the only argument."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1:
        print("usage: python -m nightloc.figures.synth OUT_DIR", file=sys.stderr)
        return 2
    out = Path(args[0])
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for world in FIGURE_POSES:
        for name, image in (
            (f"synth_{world}_day_night.png", day_night_figure(world)),
            (f"synth_{world}_map.png", map_figure(world)),
        ):
            _save_png(out / name, image)
            written.append(out / name)
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
