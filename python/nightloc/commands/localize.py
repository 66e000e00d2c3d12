"""``nightloc localize``: a recorded night log (frames + odometry) turned into a trajectory.

    nightloc localize MAP_OR_REFERENCE LOG --out OUT [--odometry FILE|none]
                      [--odometry-noise 1|DIST,HEADING] [--params FILE.toml] [--threads N]
                      [--no-figures]

MAP_OR_REFERENCE is a map file written by ``nightloc build-map`` or a reference traverse folder
with poses. LOG is a traverse folder (``images/``, no poses needed) or a video file; its odometry
is ``LOG/odometry.csv`` by default (``--odometry FILE`` for another, which a video needs; keyed by
``frame``), one row per frame: ``image,forward,left,turn`` (wheel odometry, the motion since the
previous frame in the robot's frame, metres and radians) or ``image,dx,dy`` (map frame);
``--odometry none`` localizes without odometry (every motion unknown). Each frame goes through
the grid Bayes filter (:class:`nightloc.Localizer`, ``--odometry-noise`` its noise model).

Writes, each file atomically:

* ``OUT/trajectory.csv``: ``image,x,y,heading,confidence,credible_radius,ref_index`` per frame
  (metres, radians; heading ``nan`` when the map has no headings);
* ``OUT/trajectory.png`` (unless ``--no-figures``; ``--figure-format pdf|svg`` for another
  format): the references, the estimated path with its credible radius, and the true path when
  LOG has ``poses.csv`` — then the command also prints the median and 90th-percentile distance
  errors.
"""

from __future__ import annotations

import argparse
import csv
import os
import time
from pathlib import Path

import numpy as np

from ..config import load_params_file
from ..errors import DatasetError
from ..figures import add_figure_format_option
from ..io.atomic import atomic_file, check_output_path, output_set
from ..io.odometry_csv import ODOMETRY_FILE
from ..io.reference_map import ReferenceMap
from ..io.traverse import Traverse, load_traverse
from ..localization.localizer import LocalizationParams, Localizer
from ..localization.odometry import traverse_odometry
from .camera_option import add_camera_option
from .evaluate import load_reference, parse_noise
from .wording import duration, refuse_map_as_traverse

#: Columns of ``trajectory.csv``.
TRAJECTORY_HEADER = ("image", "x", "y", "heading", "confidence", "credible_radius", "ref_index")


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the sub-command's parser to ``subparsers``."""
    parser = subparsers.add_parser(
        "localize",
        help="localize a recorded night log (frames + odometry) against a map: trajectory.csv and a figure",
        description="Runs the grid Bayes filter over every frame of LOG with its odometry and writes "
        "OUT/trajectory.csv (image,x,y,heading,confidence,credible_radius,ref_index) and OUT/trajectory.png.",
    )
    parser.add_argument("map", type=Path, help="map file (nightloc build-map) or reference traverse folder")
    parser.add_argument("log", type=Path, help="the night log: a traverse folder (images/) or a video file")
    parser.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    parser.add_argument(
        "--odometry",
        help="odometry CSV (default LOG/odometry.csv; a video needs one, keyed by frame), or 'none' for no odometry",
    )
    parser.add_argument(
        "--odometry-noise",
        default="1",
        help="the odometry's noise per frame: a Table III model (0-3) or DIST,HEADING standard deviations in "
        "metres and radians (default 1: 0.1 m, 0.02 rad)",
    )
    parser.add_argument("--params", type=Path, help="TOML file with [localization], [filter] and/or [preparation]")
    add_camera_option(
        parser, "The log's camera: it must be the map's (a reference folder is prepared for it; default panoramic)."
    )
    parser.add_argument("--threads", type=int, default=1, help="matching threads (default 1, as on a robot)")
    parser.add_argument("--no-figures", action="store_true", help="do not draw trajectory.png")
    add_figure_format_option(parser)
    parser.set_defaults(run=run)


def _load_map(path: Path, preparation, camera: str | None, params_file: Path | None) -> ReferenceMap:
    if not os.path.lexists(path):
        raise DatasetError(
            f"map {path} does not exist (a map file from nightloc build-map or a reference traverse folder)"
        )
    return load_reference(path, preparation, camera, params_file)  # a FIFO, device or link loop is named


def _log_odometry(log: Traverse, option: str | None) -> list:
    """The log's odometry: ``--odometry FILE``, or the log's own (its ``odometry.csv``)."""
    if option is None and not log.is_video and not os.path.lexists(Path(log.root) / ODOMETRY_FILE):
        raise DatasetError(
            f"the log {log.root} has no {ODOMETRY_FILE} (its wheel odometry, one row per frame: "
            f"image,forward,left,turn or image,dx,dy); name one with --odometry FILE, or localize without odometry: "
            f"--odometry none"
        )
    try:
        return traverse_odometry(log, None if option is None else Path(option))
    except DatasetError as error:
        if log.is_video and option is None:
            raise DatasetError(f"{error}: --odometry FILE, or localize without odometry: --odometry none") from None
        raise


def write_trajectory_csv(path: Path, names, estimates) -> Path:
    """Writes ``trajectory.csv`` (header :data:`TRAJECTORY_HEADER`) atomically."""
    with atomic_file(path, "w", newline="") as stream:
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(TRAJECTORY_HEADER)
        for name, e in zip(names, estimates):
            writer.writerow(
                [
                    name,
                    f"{e.x:.4f}",
                    f"{e.y:.4f}",
                    f"{e.heading:.5f}",
                    f"{e.confidence:.4f}",
                    f"{e.credible_radius:.4f}",
                    e.ref_index,
                ]
            )
    return path


def run(args: argparse.Namespace) -> int:
    """Runs the sub-command; returns the exit status (errors raise, the CLI prints one line)."""
    noise = parse_noise(args.odometry_noise)
    if args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    sections = load_params_file(args.params) if args.params is not None else {}
    params = sections.get("localization", LocalizationParams())
    inputs = (args.map, args.log, args.params, args.odometry if args.odometry not in (None, "none") else None)
    check_output_path(args.out, folder=True, inputs=inputs)  # a file in the way fails now
    refuse_map_as_traverse(args.log, "LOG", "the map comes first: nightloc localize MAP LOG --out OUT")
    log = load_traverse(args.log)
    no_odometry = args.odometry is not None and args.odometry.strip().lower() == "none"
    if no_odometry:
        odometry: list = [None] * len(log)
    else:
        odometry = _log_odometry(log, args.odometry)
    ref_map = _load_map(args.map, sections.get("preparation"), args.camera, args.params)
    ref_map.check_frames(log.read(0).shape, f"the log {log.root}", args.camera)
    localizer = Localizer(
        ref_map, params, odometry_noise=noise, filter_params=sections.get("filter"), threads=args.threads
    )
    # Checked and locked before the work; the files appear together at the end, or not at all.
    with output_set(args.out, command="localize", inputs=inputs) as out:
        start = time.perf_counter()
        estimates = [
            localizer.update(frame, odometry[i]) for i, frame in log.frames(progress_desc=f"localizing {log.root.name}")
        ]
        seconds = time.perf_counter() - start
        written = [write_trajectory_csv(out / "trajectory.csv", log.names, estimates).name]
        positions = np.array([(e.x, e.y) for e in estimates])
        truth = None if log.positions is None else np.asarray(log.positions, dtype=np.float64)
        if not args.no_figures:
            from ..figures._common import figure_path
            from ..figures.trajectory import trajectory_figure

            source = "none" if no_odometry else "the log's"
            caption = (
                f"{len(estimates)} frames of {log.root.name} against {len(ref_map)} references; odometry: "
                f"{source}, noise {args.odometry_noise}; disks: credible radius "
                f"({localizer.filter_params.credibility:.0%})"
            )
            figure = figure_path(out.path, "trajectory", args.figure_format)
            trajectory_figure(
                ref_map.positions,
                positions,
                truth,
                credible_radius=np.array([e.credible_radius for e in estimates]),
                title="nightloc localize: the Bayes filter's trajectory",
                caption=caption,
                path=figure,
                figure_format=args.figure_format,
            )
            written.append(figure.name)
    print(
        f"{len(estimates)} frames of {log.root} localized against {len(ref_map)} references in {duration(seconds)} "
        f"({duration(seconds / max(len(estimates), 1))} per frame)"
    )
    if truth is not None:
        errors = np.hypot(*(positions - truth).T)
        print(
            f"distance error against {log.root.name}'s poses: median {np.median(errors):.2f} m, "
            f"90th percentile {np.percentile(errors, 90):.2f} m"
        )
    print(f"wrote {args.out}/" + ", ".join(written))
    return 0
