"""``nightloc synth``: render the synthetic day/night datasets into traverse folders."""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

from .._validate import MAX_CAMERA_RAYS, MAX_CAMERA_SIDE
from ..io.atomic import output_set
from ..synth.creek import CREEK_DARKNESS, make_creek_dataset
from ..synth.dataset import DEFAULT_DARKNESS, DEFAULT_SEED, make_dataset
from ..synth.nights import NIGHTS, parse_nights
from ..synth.render import Camera
from ..synth.season import BAD_NIGHTS, SEASON_WORLDS
from ..synth.sensor import MAX_DARKNESS
from ..synth.world import ALL_WORLDS, WORLD_NAMES


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "synth",
        help="render the synthetic garden / living-room traverses (day reference, night queries)",
        description=(
            "Renders the synthetic world's traverses (the paper's Table I) as traverse folders "
            "OUT/<traverse>/images + poses.csv, and OUT/dataset.json, as one set (all or nothing). With "
            "--world all, each world goes to OUT/<world>/. Same seed -> byte-identical images."
        ),
    )
    parser.add_argument(
        "--world",
        choices=(*ALL_WORLDS, "creek", "all"),
        default="garden",
        help="which world (default garden; all = the default dataset's, garden and living_room; large_garden is "
        "the 25x15 m lawn of the teach run, about 1000 frames; creek is the paper's 500 m unlit bushland path for "
        f"route mode: a forward camera, 272 day and 315 night frames, darkness {CREEK_DARKNESS:g} unless --darkness "
        "is given)",
    )
    parser.add_argument("--out", required=True, type=Path, help="output folder (created with its parents if missing)")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"random seed (default {DEFAULT_SEED})")
    parser.add_argument(
        "--darkness",
        type=float,
        default=None,
        help=f"night darkness in [0, {MAX_DARKNESS:g}]: 0 = night lights exposed like day, 1 = 100x fewer photons "
        f"(default {DEFAULT_DARKNESS}; creek {CREEK_DARKNESS})",
    )
    parser.add_argument("--size", default="192x96", help="panorama WIDTHxHEIGHT in pixels (default 192x96)")
    parser.add_argument(
        "--camera",
        choices=("panoramic", "forward"),
        default="panoramic",
        help="panoramic (default) or forward: frames cut to the panorama's forward 90 degrees, the day reference "
        "driven looking four ways",
    )
    parser.add_argument("--tilt", type=float, default=0.0, help="std of each frame's pitch and roll, degrees")
    parser.add_argument("--height-jitter", type=float, default=0.0, help="std of each frame's camera height, metres")
    parser.add_argument(
        "--pattern",
        choices=("rows", "columns"),
        default="rows",
        help="the large garden's mowing pattern: rows along x (default) or columns along y (another night drive)",
    )
    parser.add_argument(
        "--nights",
        default=None,
        metavar="NAMES",
        help="render these nights (comma-separated, or all) instead of the paper's Table I night traverses, each as "
        "OUT/night_reference_NAME (the day path driven again) and OUT/night_query_NAME (the other path); the usual "
        "night keeps the names night_reference and night_query. Nights: "
        + "; ".join(f"{night.name} ({night.description})" for night in NIGHTS.values())
        + ". Not for --world creek",
    )
    parser.add_argument(
        "--season",
        type=int,
        default=None,
        metavar="N",
        help="render a season of N consecutive nights of --world garden or large_garden instead of the night "
        "traverses: each night OUT/season_NNN (the day path driven again, its own wheel odometry) under its own "
        "light (lamps, lanterns, the moon's phase, clouds, fog) and scene (grass height and mowing stripes, leaves, "
        "wet ground, furniture moved, a playhouse put up, a bench taken away), every --test-every nights "
        "OUT/season_NNN_query (the other path); each night's conditions in dataset.json under season",
    )
    parser.add_argument(
        "--test-every", type=int, default=None, metavar="K", help="--season: a test drive every K nights (default 3)"
    )
    parser.add_argument(
        "--bad-nights",
        default=None,
        metavar="SPEC",
        help="--season: bad nights as NIGHT:KIND items, e.g. 10:covered,17:kidnapped,24:other_garden (kinds: "
        + ", ".join(BAD_NIGHTS)
        + ")",
    )
    parser.add_argument("--overwrite", action="store_true", help="replace a dataset that exists at OUT")
    parser.add_argument("--threads", type=int, default=None, help="render threads (default all cores)")
    parser.set_defaults(run=run)


def parse_size(text: str) -> tuple[int, int]:
    """``"192x96"`` -> ``(192, 96)``; a clear ValueError for anything else."""
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise ValueError(f"--size must be WIDTHxHEIGHT in pixels, e.g. 192x96, got {text!r}")
    width, height = (int(p) for p in parts)
    if width < 8 or height < 4:
        raise ValueError(f"--size must be at least 8x4 pixels, got {text!r}")
    if max(width, height) > MAX_CAMERA_SIDE:
        raise ValueError(f"--size {text} is too large: at most {MAX_CAMERA_SIDE} pixels along a side (MAX_CAMERA_SIDE)")
    rays = width * height * Camera.oversample_x * Camera.oversample_y
    if rays > MAX_CAMERA_RAYS:
        raise ValueError(
            f"--size {text} is too large: {rays} rays per frame with the default oversampling, at most "
            f"{MAX_CAMERA_RAYS} (MAX_CAMERA_RAYS, about 180 bytes each while a frame renders)"
        )
    return width, height


def run(args: argparse.Namespace) -> int:
    if args.darkness is None:
        args.darkness = CREEK_DARKNESS if args.world == "creek" else DEFAULT_DARKNESS
    if args.seed < 0:
        raise ValueError("--seed must be >= 0")
    if not (math.isfinite(args.darkness) and 0.0 <= args.darkness <= MAX_DARKNESS):
        raise ValueError(f"--darkness must be in [0, {MAX_DARKNESS:g}], got {args.darkness}")
    if args.threads is not None and args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    camera = Camera(*parse_size(args.size))
    for name, value in (("--tilt", args.tilt), ("--height-jitter", args.height_jitter)):
        if not (math.isfinite(value) and 0.0 <= value <= 20.0):
            raise ValueError(f"{name} must be in [0, 20], got {value}")
    if args.pattern != "rows" and args.world != "large_garden":
        raise ValueError(f"--pattern applies to --world large_garden only, got --world {args.world}")
    looks = {"view": args.camera, "tilt_deg": args.tilt, "height_std": args.height_jitter}
    if args.pattern != "rows":
        looks["pattern"] = args.pattern
    if args.nights is not None:
        if args.world == "creek":
            raise ValueError(
                "--nights applies to the garden, living_room and large_garden worlds, not to --world creek"
            )
        looks["nights"] = parse_nights(args.nights)
    if args.season is not None:
        if args.world not in SEASON_WORLDS:
            raise ValueError(f"--season applies to --world {' or '.join(SEASON_WORLDS)}, not {args.world}")
        if args.nights is not None or args.pattern != "rows" or args.camera != "panoramic":
            raise ValueError(
                "--season renders its own nights with the panorama and the rows pattern: "
                "not with --nights, --pattern or --camera forward"
            )
        looks.update(season=args.season, test_every=args.test_every or 3, bad_nights=args.bad_nights)
    elif args.bad_nights is not None or args.test_every is not None:
        raise ValueError("--bad-nights and --test-every are about a season's nights: give --season N too")
    start = time.perf_counter()
    if args.world == "creek":
        if args.size != "192x96" or args.camera != "panoramic" or args.tilt or args.height_jitter:
            raise ValueError(
                "--world creek has its own forward camera: --size, --camera, --tilt and --height-jitter do "
                "not apply to it"
            )
        written = {
            "creek": make_creek_dataset(args.out, args.seed, args.darkness, overwrite=args.overwrite, parents=True)
        }
    elif args.world == "all":  # one set holding every world: all appear together, or none changes
        with output_set(args.out, command="synth", overwrite=args.overwrite, parents=True) as out:
            written = {
                world: make_dataset(
                    world, out / world, args.seed, args.darkness, camera=camera, threads=args.threads, **looks
                )
                for world in WORLD_NAMES
            }
        written = {world: {n: args.out / world / n for n in folders} for world, folders in written.items()}
    else:
        written = {
            args.world: make_dataset(
                args.world,
                args.out,
                args.seed,
                args.darkness,
                camera=camera,
                overwrite=args.overwrite,
                threads=args.threads,
                parents=True,
                **looks,
            )
        }
    for world, folders in written.items():
        for name, folder in folders.items():
            frames = sum(1 for _ in (folder / "images").iterdir())
            print(f"{world}/{name}: {frames} frames -> {folder}")
    print(f"done in {time.perf_counter() - start:.1f} s (seed {args.seed}, darkness {args.darkness})")
    return 0
