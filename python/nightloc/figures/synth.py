"""Figures of the synthetic worlds: day vs night panoramas, and maps.

    python -m nightloc.figures.synth docs/figures [--figure-format png|pdf|svg]

writes ``synth_<world>_day_night.<fmt>`` (a day and a night panorama of the same pose, and both
prepared as the matcher sees them, on azimuth/elevation axes) and ``synth_<world>_map.<fmt>``
(the world from above by day, in metres, with the object outlines, the mapped area and the
traverses: day reference red, night reference green, night query blue, as the paper's Figures
4b and 5b).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Polygon, Rectangle

from ..preparation.preparer import prepare
from ..synth.dataset import DEFAULT_DARKNESS, DEFAULT_SEED, SynthScene
from ..synth.geometry import polygon_of
from ..synth.paths import plan_traverses
from . import add_figure_format_option
from ._common import figure_path, new_figure, save_figure, styled

__all__ = ["FIGURE_POSES", "TRAVERSE_COLOURS", "day_night_figure", "main", "map_figure"]

#: The pose (x, y, heading) shown in each world's day/night figure.
FIGURE_POSES = {"garden": (3.5, 2.5, -1.3), "living_room": (2.5, 1.2, np.pi / 2)}

#: Colour of each traverse on the maps (the paper's Figures 4b and 5b).
TRAVERSE_COLOURS = {"day_reference": "tab:red", "night_reference": "tab:green", "night_query": "tab:blue"}

#: Ground texture resolution of the map figure, pixels per metre (the world's is finer).
MAP_PIXELS_PER_METRE = 40


def _panorama(ax, image: np.ndarray, scene: SynthScene, title: str, grey: bool = False) -> None:
    """``image`` on azimuth (degrees clockwise from the heading, as the columns run) and
    elevation axes."""
    camera = scene.camera
    extent = (0.0, 360.0, camera.elevation_bottom_deg, camera.elevation_top_deg)
    shown = image if grey else cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    kwargs = {"cmap": "gray", "vmin": 0, "vmax": 255} if grey else {}
    ax.imshow(shown, extent=extent, origin="upper", aspect="auto", interpolation="nearest", **kwargs)
    ax.set_box_aspect(image.shape[0] / image.shape[1])
    ax.set_xticks([0, 90, 180, 270, 360])
    ax.set_title(title)
    ax.grid(False)


@styled
def day_night_figure(
    world: str = "garden",
    pose: tuple[float, float, float] | None = None,
    seed: int = DEFAULT_SEED,
    darkness: float = DEFAULT_DARKNESS,
    path: str | Path | None = None,
    figure_format: str | None = None,
) -> Figure:
    """A day and a night panorama (camera size, 192 x 96 by default) of the same pose, above both
    prepared (48 x 24: equalized, patch-normalized) as the matcher sees them."""
    scene = SynthScene(world, seed, darkness)
    x, y, heading = pose if pose is not None else FIGURE_POSES[world]
    day = scene.frame("day", x, y, heading, scene.frame_rng("figure_day", 0))
    night = scene.frame("night", x, y, heading, scene.frame_rng("figure_night", 0))
    prepared = prepare(np.stack([day, night]))
    fig, axes = new_figure(9.0, 5.0, 2, 2)
    _panorama(axes[0, 0], day, scene, f"day: mean grey {day.mean():.0f}")
    _panorama(axes[0, 1], night, scene, f"night, darkness {darkness:g}: mean grey {night.mean():.0f}")
    for ax, image, when in zip(axes[1], prepared, ("day", "night")):
        _panorama(ax, image, scene, f"{when}, prepared {image.shape[1]}x{image.shape[0]}", grey=True)
    for ax in axes[1]:
        ax.set_xlabel("azimuth, degrees clockwise from heading")
    for ax in axes[:, 0]:
        ax.set_ylabel("elevation (deg)")
    fig.suptitle(f"{world}: x = {x:.1f} m, y = {y:.1f} m, heading {np.degrees(heading):.0f} deg")
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


@styled
def map_figure(
    world: str = "garden",
    seed: int = DEFAULT_SEED,
    path: str | Path | None = None,
    figure_format: str | None = None,
) -> Figure:
    """The world from above, in metres: day-lit ground, object outlines (white), the mapped area
    (yellow), and each traverse's positions with heading ticks 0.25 m long."""
    scene = SynthScene(world, seed)
    ground = scene.lighting["day"].ground
    linear = ground.values / np.percentile(ground.values, 99.5)
    image = np.clip(linear, 0, 1) ** (1 / 2.2)  # rows go north: origin lower
    rows, cols = image.shape[:2]
    extent = (
        ground.x0,
        ground.x0 + cols / ground.pixels_per_metre,
        ground.y0,
        ground.y0 + rows / ground.pixels_per_metre,
    )
    scale = MAP_PIXELS_PER_METRE / ground.pixels_per_metre
    if scale < 1:
        image = cv2.resize(image.astype(np.float32), None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    width_m, height_m = extent[1] - extent[0], extent[3] - extent[2]
    fig, ax = new_figure(7.0, max(3.0, 7.0 * height_m / width_m * 0.9 + 1.7))
    ax.imshow(image, extent=extent, origin="lower", interpolation="bilinear")
    for obj in scene.world.objects:
        if obj.top > 0.05 and obj.bottom < 2.6:
            ax.add_patch(Polygon(polygon_of(obj), closed=True, fill=False, edgecolor="white", linewidth=0.8))
    x0, y0, x1, y1 = scene.world.mapped_area
    ax.add_patch(
        Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor="yellow", linewidth=1.2, label="mapped area")
    )
    for plan in plan_traverses(world, seed):
        colour = TRAVERSE_COLOURS[plan.name]
        px, py = plan.positions[:, 0], plan.positions[:, 1]
        ax.quiver(
            px,
            py,
            np.cos(plan.headings),
            np.sin(plan.headings),
            color=colour,
            angles="xy",
            scale_units="xy",
            scale=4.0,  # 0.25 m
            width=0.003,
            headwidth=0,
            headlength=0,
            headaxislength=0,
        )
        ax.scatter(
            px,
            py,
            s=14,
            color=colour,
            edgecolors="white",
            linewidths=0.4,
            zorder=3,
            label=f"{plan.name.replace('_', ' ')} ({len(px)} frames)",
        )
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(False)
    fig.legend(loc="outside lower center", ncols=2)
    ax.set_title(f"{world.replace('_', ' ')} from above, by day (seed {seed})")
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


def main(argv: Sequence[str] | None = None) -> int:
    """Writes the figures of both worlds into the folder given; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m nightloc.figures.synth",
        description="Draws the day/night and map figures of the synthetic worlds into OUT_DIR.",
    )
    parser.add_argument(
        "out", type=Path, metavar="OUT_DIR", help="output folder (created if missing; its parent must exist)"
    )
    add_figure_format_option(parser)
    try:
        args = parser.parse_args(list(sys.argv[1:] if argv is None else argv))
    except SystemExit as exit_:
        return int(exit_.code or 0)
    if not args.out.parent.is_dir():
        print(f"{parser.prog}: error: the parent folder of {args.out} does not exist", file=sys.stderr)
        return 2
    args.out.mkdir(exist_ok=True)
    written: list[Path] = []
    for world in FIGURE_POSES:
        for stem, draw in (("day_night", day_night_figure), ("map", map_figure)):
            target = figure_path(args.out, f"synth_{world}_{stem}", args.figure_format)
            draw(world, path=target)
            written.append(target)
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
