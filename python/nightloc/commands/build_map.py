"""``nightloc build-map TRAVERSE OUT.map``: prepare a traverse into a reference map file."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..config import load_params
from ..errors import DatasetError
from ..io.atomic import check_output_path
from ..io.reference_map import ReferenceMap
from ..io.traverse import Traverse, load_traverse
from ..preparation.camera import shape_camera
from ..preparation.params import PreparationParams
from .bag_options import add_bag_options, bag_options
from .camera_option import add_camera_option, preparation_for_camera
from .wording import duration


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "build-map",
        help="prepare a traverse (folder or video + poses) into a reference map file",
        description=(
            "Reads TRAVERSE (a folder with images/ and poses.csv, a video with --poses, or a ROS bag with a pose "
            "topic), prepares "
            "every frame (crop, greyscale, equalization, 48x24 area downsample, patch normalization) "
            "and writes one reference map file that nightloc.ReferenceMap.load reads on the robot. An existing "
            "map is replaced only with --overwrite; the map may not lie inside the traverse."
        ),
    )
    parser.add_argument("traverse", type=Path, help="traverse folder, a video file or a ROS bag")
    parser.add_argument("output", type=Path, help="map file to write (e.g. garden.map)")
    parser.add_argument("--params", type=Path, help="TOML file with a [preparation] table (default: paper values)")
    add_camera_option(parser, "Stored in the map; default panoramic, or the wrap of --params.")
    parser.add_argument("--poses", type=Path, help="poses CSV (for a video: frame,x,y[,heading])")
    parser.add_argument("--frame-step", type=int, default=1, help="keep every k-th frame (default 1)")
    parser.add_argument("--overwrite", action="store_true", help="replace OUT.map when it exists")
    add_bag_options(parser)
    parser.set_defaults(run=run)


def no_poses_error(traverse: Traverse) -> DatasetError:
    """What to do with a traverse without poses: add them, or match along the route."""
    return DatasetError(
        f"{traverse.root} has no poses, and a 2D map needs the position of every frame: add them (poses.csv with "
        f"columns image,x,y[,heading], a video's --poses CSV, or a bag's pose topic). Without positions, a robot "
        f"that drives the same route again can localize along it: nightloc route {traverse.root} NIGHT_LOG --out OUT. "
        f"(A map from the robot's odometry alone, a teach run, is not built yet.)"
    )


def run(args: argparse.Namespace) -> int:
    if args.frame_step < 1:
        raise ValueError(f"--frame-step must be >= 1, got {args.frame_step}")
    params = load_params(args.params, PreparationParams) if args.params is not None else None
    params = preparation_for_camera(params, args.camera, args.params) or PreparationParams()
    # names, times and poses only
    traverse = load_traverse(args.traverse, frame_step=args.frame_step, poses=args.poses, **bag_options(args))
    if not traverse.has_poses:
        raise no_poses_error(traverse)
    # Fail before preparing every frame: a folder, a missing parent, an existing map without
    # --overwrite, or a map that would land on or inside an input (a frame of the traverse).
    check_output_path(args.output, overwrite=args.overwrite, inputs=(args.traverse, args.poses, args.params))
    start = time.perf_counter()
    reference_map = ReferenceMap.build(traverse, params)
    elapsed = time.perf_counter() - start
    written = reference_map.save(args.output, overwrite=args.overwrite)
    kind = "360-degree panoramas" if params.wrap else "forward camera"
    print(
        f"{len(reference_map)} frames of {traverse.root} prepared to {params.width}x{params.height} "
        f"({kind}, equalize={params.equalize}) in {duration(elapsed)} "
        f"({len(reference_map) / max(elapsed, 1e-9):.0f} frames/s)"
    )
    if reference_map.frame_size is not None:
        width, height = reference_map.frame_size
        looks = shape_camera(width, height)
        if looks != reference_map.camera and args.camera is None:
            print(
                f"note: the frames are {width}x{height}, the shape of a {looks} camera's, but the map is prepared "
                f"for a {reference_map.camera} camera; if the camera is {looks}, rebuild with --camera {looks}"
            )
    extent_min = reference_map.positions.min(axis=0)
    extent_max = reference_map.positions.max(axis=0)
    print(
        f"positions span x {extent_min[0]:.2f}..{extent_max[0]:.2f} m, y {extent_min[1]:.2f}..{extent_max[1]:.2f} m; "
        f"headings {'yes' if reference_map.headings is not None else 'no'}; camera {reference_map.camera}"
    )
    print(f"wrote {written} ({written.stat().st_size / 1024:.1f} KiB)")
    return 0
