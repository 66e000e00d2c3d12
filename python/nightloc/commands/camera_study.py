"""``nightloc camera-study``: which camera a robot needs -- resolution x darkness x sensor -> error.

Renders a synthetic world's night drives at every darkness level and with every sensor pixel,
localizes them at every matching resolution with the paper's method and the grid filter, and
writes OUT/camera_study.csv and OUT/figures/camera_study.<format> as one set
(:mod:`nightloc.studies.camera`; docs/camera_study.md explains the sensor model).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..figures import add_figure_format_option
from ..io.atomic import output_set
from ..studies.camera import (
    DEFAULT_DARKNESS_LEVELS,
    DEFAULT_SENSORS,
    DEFAULT_SIZES,
    Sensor,
    StudySettings,
    numbers_from_text,
    run_camera_study,
    sensors_from_text,
    sizes_from_text,
)
from ..synth.sensor import MAX_DARKNESS
from ..synth.world import ALL_WORLDS

#: The grid of ``--quick`` (for tests: two resolutions, two light levels, one sensor, one draw).
QUICK = {"sizes": ((12, 6), (48, 24)), "darkness": (0.0, 2.0), "sensors": (Sensor(),), "draws": 1}


def _sizes_text(sizes: tuple[tuple[int, int], ...]) -> str:
    return ",".join(f"{w}x{h}" for w, h in sizes)


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "camera-study",
        help="which camera a robot needs: matching resolution x night darkness x sensor pixel -> error",
        description=(
            "Renders a synthetic world's night drives at each darkness level and with each sensor pixel, localizes "
            "them at each matching resolution (paper's method and grid filter, several noise draws) and writes "
            "OUT/camera_study.csv and OUT/figures/camera_study.png as one set; prints, per light level, the smallest "
            "resolution within 10 % of the best."
        ),
    )
    parser.add_argument("--world", choices=ALL_WORLDS, default="garden", help="synthetic world (default garden)")
    parser.add_argument("--out", required=True, type=Path, help="output folder (created with its parents if missing)")
    parser.add_argument(
        "--sizes",
        default=_sizes_text(DEFAULT_SIZES),
        help=f"matching resolutions WIDTHxHEIGHT (default {_sizes_text(DEFAULT_SIZES)})",
    )
    parser.add_argument(
        "--darkness",
        default=",".join(f"{d:g}" for d in DEFAULT_DARKNESS_LEVELS),
        help=f"night darkness levels in [0, {MAX_DARKNESS:g}]; each step of 1 is 100x fewer photons (default "
        f"{','.join(f'{d:g}' for d in DEFAULT_DARKNESS_LEVELS)})",
    )
    parser.add_argument(
        "--sensors",
        default=",".join(f"{s.full_well:g}:{s.read_noise:g}" for s in DEFAULT_SENSORS),
        help="pixels as FULL_WELL:READ_NOISE in electrons (default "
        f"{','.join(f'{s.full_well:g}:{s.read_noise:g}' for s in DEFAULT_SENSORS)}: 1, 2, 4 and 8 um pixels)",
    )
    parser.add_argument("--draws", type=int, default=5, help="noise draws per cell (default 5)")
    parser.add_argument("--seed", type=int, default=0, help="world and noise seed (default 0)")
    parser.add_argument("--seq-len", type=int, default=7, help="the paper's sequence length (default 7)")
    parser.add_argument("--noise-model", type=int, default=1, help="Table III odometry noise model (default 1)")
    parser.add_argument("--method", default="paper,filter", help="paper, filter or paper,filter (default both)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a small grid for tests: 12x6 and 48x24, darkness 0 and 2, the 4000:2.5 sensor, one draw "
        "(replaces --sizes, --darkness, --sensors and --draws)",
    )
    parser.add_argument("--threads", type=int, help="matching and render threads (default all cores)")
    add_figure_format_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.threads is not None and args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    if args.quick:
        grid = dict(QUICK)
    else:
        grid = {
            "sizes": sizes_from_text(args.sizes),
            "darkness": numbers_from_text(args.darkness, "--darkness"),
            "sensors": sensors_from_text(args.sensors),
            "draws": args.draws,
        }
    settings = StudySettings(
        **grid,  # type: ignore[arg-type]
        seed=args.seed,
        seq_len=args.seq_len,
        noise_model=args.noise_model,
        methods=tuple(m.strip() for m in args.method.split(",")),
    )
    from ..figures.camera_study import camera_study_figure

    start = time.perf_counter()
    with output_set(args.out, command="camera-study", parents=True) as out:
        study = run_camera_study(args.world, settings, args.threads)
        study.write_csv(out / "camera_study.csv")
        (out / "figures").mkdir()
        camera_study_figure(study, path=out / "figures" / f"camera_study.{args.figure_format}")
    draws = f"{settings.draws} noise draw{'s' if settings.draws != 1 else ''}"
    print(f"camera study of {args.world}: {len(study.rows)} cells, {draws}")
    print("smallest resolution within 10 % of the best median, per light level and sensor:")
    for line in study.summary_lines():
        print(f"  {line}")
    print(f"wrote {args.out / 'camera_study.csv'} and {args.out / 'figures'} in {time.perf_counter() - start:.0f} s")
    return 0
