"""``nightloc export-log LOG OUT``: a log written again in the layout the firmware replay reads.

    nightloc export-log LOG OUT [--odometry FILE] [--overwrite] [--image-topic T] [--odometry-topic T]
                        [--pose-topic T] [--sync-tolerance S]

LOG is any log ``nightloc localize`` reads: a folder (``images/`` in any format nightloc reads,
``odometry.csv`` keyed by file name, e.g. a ``nightloc synth`` traverse), a video with
``--odometry FILE`` or a ROS bag. OUT becomes a folder that ``nightloc_replay MAP OUT
trajectory.csv`` reads (cpp/apps/): ``images/`` of 8-bit binary PGM (grey) or PPM (colour) frames,
``odometry.csv`` with the rows renamed to match (and the motions ``localize`` uses: rows between
kept frames composed), the log's times in its ``timestamp`` column and its poses in ``poses.csv``
(:func:`nightloc.io.firmware_log.write_firmware_log`). Written as one set; LOG is only read; an
existing OUT is replaced only with ``--overwrite`` and only when it is a log.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..io.atomic import check_output_path
from ..io.firmware_log import write_firmware_log
from ..io.traverse import load_traverse
from .options import add_bag_options, bag_options, log_odometry
from .wording import duration, refuse_map_as_traverse


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the sub-command's parser to ``subparsers``."""
    parser = subparsers.add_parser(
        "export-log",
        help="write a log (frames + odometry) as the firmware replay (nightloc_replay) reads it: PGM/PPM frames",
        description="Writes LOG (a folder, a video with --odometry, or a ROS bag) to the folder OUT in the layout "
        "nightloc_replay reads: OUT/images/ of 8-bit binary PGM (grey) or PPM (colour) frames, OUT/odometry.csv with "
        "the rows renamed to match and the log's times, OUT/poses.csv when the log has poses. All or nothing; LOG is "
        "only read.",
    )
    parser.add_argument("log", type=Path, help="the log: a traverse folder (images/, odometry.csv), a video or a bag")
    parser.add_argument("out", type=Path, help="the folder to write (created with its parents if missing)")
    parser.add_argument(
        "--odometry", help="odometry CSV (default LOG/odometry.csv or a bag's own; a video needs one, keyed by frame)"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing OUT (only a log folder)")
    add_bag_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Runs the sub-command; returns the exit status (errors raise, the CLI prints one line)."""
    check_output_path(args.out, folder=True, inputs=(args.log, args.odometry), parents=True)
    refuse_map_as_traverse(args.log, "LOG", "nightloc export-log LOG OUT takes a log (frames and odometry)")
    start = time.perf_counter()
    log = load_traverse(args.log, **bag_options(args))
    odometry = log_odometry(log, args.odometry, "")
    exported = write_firmware_log(log, args.out, odometry, overwrite=args.overwrite)
    frames = sorted({Path(name).suffix for name in exported.names})
    print(
        f"wrote {args.out}: {len(exported)} {'/'.join(s.lstrip('.').upper() for s in frames)} frames, odometry.csv"
        + (" with times" if exported.timestamps is not None else "")
        + (", poses.csv" if exported.has_poses else "")
        + f" ({duration(time.perf_counter() - start)}); replay it: nightloc_replay MAP {args.out} trajectory.csv"
    )
    return 0
