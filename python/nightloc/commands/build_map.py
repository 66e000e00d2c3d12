"""``nightloc build-map TRAVERSE OUT.map``: prepare a traverse into a reference map file.

With ``poses.csv`` the map takes the surveyed poses. ``--params`` (and ``--set``) give the
``[preparation]`` the frames are prepared with and the ``[localization]`` and ``[filter]``
settings the map keeps (:attr:`nightloc.ReferenceMap.settings`): its file carries the filter's
tables made with them, and ``nightloc localize``, ``nightloc.Localizer(map)``, the node and the
firmware run them. Without it, from the drive's wheel odometry
(``odometry.csv``: ``image,forward,left,turn``) the map is a **teach run**
(:func:`nightloc.mapping.teach_run`): dead reckoning corrected by a pose graph of the images'
relative headings and revisits, in the drive's odometry frame. ``--evaluate-poses`` runs the
teach run on a traverse that has both and reports the ATE of the dead reckoning and of the map
against ``poses.csv``; ``--figure`` draws the paths.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings
from pathlib import Path

import numpy as np

from ..errors import DatasetError
from ..io.atomic import check_output_path, parent_folders
from ..io.odometry_csv import ODOMETRY_FILE
from ..io.traverse import Traverse, load_traverse
from ..localization.grid_filter import FilterParams
from ..localization.localizer import LocalizationParams
from ..mapping.reference_map import LOCALIZER_SECTIONS, ReferenceMap
from ..preparation.camera import shape_camera
from ..preparation.params import PreparationParams
from .options import (
    add_bag_options,
    add_camera_option,
    add_params_options,
    bag_options,
    preparation_for_camera,
    read_settings,
    settings_line,
    traverse_camera,
)
from .wording import duration


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "build-map",
        help="prepare a traverse (poses.csv, or wheel odometry: a teach run) into a reference map file",
        description=(
            "Reads TRAVERSE (a folder with images/ and poses.csv, a video with --poses, or a ROS bag with a pose "
            "topic), prepares "
            "every frame (crop, greyscale, equalization, 48x24 area downsample, patch normalization) "
            "and writes one reference map file that nightloc.ReferenceMap.load reads on the robot. A folder "
            "with odometry.csv (image,forward,left,turn) and no poses.csv is a teach run: the poses come from "
            "the wheel odometry corrected by a pose graph of the images (GTSAM: pip install 'nightloc[mapping]'). "
            "An existing map is replaced only with --overwrite; the map may not lie inside the traverse."
        ),
    )
    parser.add_argument("traverse", type=Path, help="traverse folder, a video file or a ROS bag")
    parser.add_argument("output", type=Path, help="map file to write (e.g. garden.map)")
    add_params_options(
        parser,
        "[preparation] (default: paper values), the [localization] and [filter] settings the map keeps, and for a "
        "teach run [teach]",
    )
    add_camera_option(parser, "Stored in the map; default panoramic, or the wrap of --params.")
    parser.add_argument("--poses", type=Path, help="poses CSV (for a video: frame,x,y[,heading])")
    parser.add_argument("--frame-step", type=int, default=1, help="keep every k-th frame (default 1)")
    parser.add_argument(
        "--evaluate-poses",
        action="store_true",
        help="teach run on a traverse that also has poses.csv: build from the odometry, report the ATE of dead "
        "reckoning and of the map against poses.csv",
    )
    parser.add_argument("--closed-loop", action="store_true", help="teach run: the drive ends where it began (a dock)")
    parser.add_argument("--figure", type=Path, help="teach run: draw the paths to this PNG, PDF or SVG file")
    parser.add_argument("--overwrite", action="store_true", help="replace OUT.map when it exists")
    add_bag_options(parser)
    parser.set_defaults(run=run)


def no_poses_error(traverse: Traverse) -> DatasetError:
    """What to do with a traverse without poses: add them, or match along the route."""
    return DatasetError(
        f"{traverse.root} has no poses, and a 2D map needs the position of every frame: add them (poses.csv with "
        f"columns image,x,y[,heading], a video's --poses CSV, or a bag's pose topic). Without positions, a robot "
        f"that drives the same route again can localize along it: nightloc route {traverse.root} NIGHT_LOG --out OUT; "
        f"or, with the drive's wheel odometry ({ODOMETRY_FILE}: image,forward,left,turn) beside images/, build-map "
        f"builds the map by a teach run"
    )


def run(args: argparse.Namespace) -> int:
    if args.frame_step < 1:
        raise ValueError(f"--frame-step must be >= 1, got {args.frame_step}")
    settings = read_settings(args)
    params = settings.section(PreparationParams)
    # names, times and poses only
    traverse = load_traverse(args.traverse, frame_step=args.frame_step, poses=args.poses, **bag_options(args))
    camera, camera_said_by = traverse_camera(traverse, args.camera, settings)
    params = preparation_for_camera(params, camera, settings) or PreparationParams()
    teach = args.evaluate_poses or not traverse.has_poses
    if args.evaluate_poses and not traverse.has_poses:
        where = "a pose topic (--pose-topic)" if traverse.is_bag else f"{args.traverse}/poses.csv"
        raise DatasetError(f"--evaluate-poses needs {where} to compare the teach run with")
    if not teach and (args.closed_loop or args.figure is not None):
        raise ValueError("--closed-loop and --figure apply to a teach run (no poses.csv, or --evaluate-poses)")
    if traverse.is_bag:
        has_odometry = traverse.motions is not None
    else:
        has_odometry = not traverse.is_video and (Path(traverse.root) / ODOMETRY_FILE).is_file()
    if teach and not has_odometry:
        raise no_poses_error(traverse)
    # Fail before preparing every frame: a folder, a parent that is a file, an existing map without
    # --overwrite, or a map that would land on or inside an input (a frame of the traverse).
    check_output_path(
        args.output, overwrite=args.overwrite, inputs=(args.traverse, args.poses, args.params), parents=True
    )
    if args.figure is not None:
        check_output_path(args.figure, overwrite=True, inputs=(args.traverse, args.poses, args.params, args.output))
    with parent_folders(args.output):  # maps/garden.map creates maps/ (removed again on a failure)
        if teach:
            return _teach(args, traverse, params, camera_said_by, settings)
        return _survey(args, traverse, params, camera_said_by, settings)


def _keep_settings(reference_map: ReferenceMap, settings) -> ReferenceMap:
    """The map keeping the ``[localization]`` and ``[filter]`` settings of ``--params``/``--set``
    (the sections they give)."""
    return reference_map.with_settings(settings.section(LocalizationParams), settings.section(FilterParams))


def _print_kept(settings) -> None:
    print(settings_line(settings, LOCALIZER_SECTIONS, lead="localizer settings kept in the map"))


def _survey(
    args: argparse.Namespace, traverse: Traverse, params: PreparationParams, camera_said_by: str | None, settings
) -> int:
    start = time.perf_counter()
    reference_map = _keep_settings(ReferenceMap.build(traverse, params), settings)
    elapsed = time.perf_counter() - start
    written = reference_map.save(args.output, overwrite=args.overwrite)
    _describe(args, reference_map, traverse.root, params, elapsed, camera_said_by)
    _print_kept(settings)
    print(f"wrote {written} ({written.stat().st_size / 1024:.1f} KiB)")
    return 0


def _describe(
    args: argparse.Namespace,
    reference_map: ReferenceMap,
    root: Path,
    params: PreparationParams,
    elapsed: float,
    camera_said_by: str | None,
) -> None:
    kind = "360-degree panoramas" if params.wrap else "forward camera"
    print(
        f"{len(reference_map)} frames of {root} prepared to {params.width}x{params.height} "
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
    said_by = f" (as {camera_said_by} says)" if camera_said_by else " (the default)"
    print(
        f"positions span x {extent_min[0]:.2f}..{extent_max[0]:.2f} m, y {extent_min[1]:.2f}..{extent_max[1]:.2f} m; "
        f"headings {'yes' if reference_map.headings is not None else 'no'}; camera {reference_map.camera}{said_by}; "
        f"pose source {reference_map.pose_source}"
    )


def _teach(args: argparse.Namespace, traverse, params: PreparationParams, camera_said_by: str | None, settings) -> int:
    from ..mapping import TeachParams, TeachWarning, absolute_trajectory_error, rigid_fit, teach_run
    from ..mapping.factors import require_gtsam

    require_gtsam()  # one line naming the install command, before any work
    teach = settings.get(TeachParams)
    if args.closed_loop:
        teach = dataclasses.replace(teach, closed_loop=True)
    source = ODOMETRY_FILE if traverse.bag_topics is None else f"the bag's {traverse.bag_topics['odometry']}"
    print(f"teach run: {len(traverse)} frames of {traverse.root}, wheel odometry from {source}", flush=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TeachWarning)
        reference_map, report = teach_run(traverse, params, teach)
    for warning in caught:
        print(f"warning: {warning.message}")
    reference_map = _keep_settings(reference_map, settings)
    written = reference_map.save(args.output, overwrite=args.overwrite)
    _describe(args, reference_map, traverse.root, params, report.seconds, camera_said_by)
    _print_kept(settings)
    kinds = report.counts_by_kind()
    print(
        f"visual constraints: {report.accepted} accepted, {report.rejected} rejected "
        f"(sequence {kinds['sequence'][0]}/{kinds['sequence'][1]}, revisits {kinds['place'][0]}/{kinds['place'][1]}); "
        f"{report.gated_out} candidate pairs too far apart" + (", closed loop" if args.closed_loop else "")
    )
    if report.covariances_summary is not None:
        median, largest = report.covariances_summary
        print(f"pose uncertainty (1 sigma, larger axis): median {median:.3f} m, largest {largest:.3f} m")
    surveyed = None
    if args.evaluate_poses and traverse.positions is not None:
        truth = np.asarray(traverse.positions)
        fit = rigid_fit(reference_map.positions, truth)
        surveyed = fit.inverse().apply(truth)
        print(
            f"ATE against {'poses.csv' if traverse.bag_topics is None else traverse.bag_topics['pose']} (RMSE after "
            f"the best rigid 2D fit): dead reckoning "
            f"{absolute_trajectory_error(report.dead_reckoning[:, :2], truth):.3f} m, map "
            f"{absolute_trajectory_error(reference_map.positions, truth):.3f} m"
        )
    if args.figure is not None:
        from ..figures.teach import teach_figure

        accepted = [
            (c.i, c.j)
            for c, residual in zip(report.constraints, report.solution.residuals if report.solution else [])
            if residual <= report.accept_gate
        ]
        teach_figure(
            report.dead_reckoning,
            reference_map.positions,
            surveyed,
            np.array(accepted, dtype=int).reshape(-1, 2),
            title=f"Teach run: {traverse.root.name} ({report.pose_source})",
            path=args.figure,
        )
        print(f"figure {args.figure}")
    print(f"wrote {written} ({written.stat().st_size / 1024:.1f} KiB)")
    return 0
