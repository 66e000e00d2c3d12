"""``nightloc localize``: a recorded night log (frames + odometry) turned into a trajectory.

    nightloc localize MAP_OR_REFERENCE LOG --out OUT [--format csv|tum|mcap|csv,tum,mcap] [--min-confidence C]
                      [--odometry FILE|none] [--survey DAY]
                      [--odometry-noise wheel|1|DIST,HEADING] [--params FILE.toml] [--set SECTION.KEY=VALUE]
                      [--camera panoramic|forward]
                      [--shift-window COLUMNS,ROWS] [--image-topic T] [--odometry-topic T] [--pose-topic T]
                      [--sync-tolerance S] [--threads N] [--no-figures] [--learn NEW_MAP [--overwrite]]

MAP_OR_REFERENCE is a map file written by ``nightloc build-map`` or a reference traverse (a folder
with poses, or a bag with a pose topic). LOG is a traverse folder (``images/``, no poses needed),
a video file or a ROS bag (:mod:`nightloc.io.bag`: its image topic, its odometry topic or TF
``odom -> base_link`` matched to each frame by time). A folder's odometry is ``LOG/odometry.csv``
by default (``--odometry FILE`` for another, which a video needs; keyed by ``frame``), one row per
frame: ``image,forward,left,turn`` (wheel odometry, the motion since the previous frame in the
robot's frame, metres and radians) or ``image,dx,dy`` (map frame), optionally with a
``timestamp`` column (seconds); ``--odometry none`` localizes without odometry (every motion
unknown). Each frame goes through the grid Bayes filter (:class:`nightloc.Localizer`,
``--odometry-noise`` its noise model: by default ``wheel``, the step-scaled model, for wheel
odometry, and Table III model 1 for map-frame steps). The filter runs the ``[localization]`` and
``[filter]`` settings the map keeps (``nightloc build-map --params``), each key replaced where
``--params`` or ``--set`` gives it; the command prints which settings came from where.

Writes, each file atomically:

* ``OUT/trajectory.csv`` (``--format csv``, the default):
  ``image,x,y,heading,confidence,credible_radius,ref_index,timestamp`` per frame (metres,
  radians, seconds; heading ``nan`` when the map has no headings, timestamp ``nan`` when the log
  carries no times);
* ``OUT/trajectory.tum`` (``--format tum``): ``timestamp x y z qx qy qz qw`` per frame, the TUM
  format ``evo`` reads (:mod:`nightloc.io.trajectory`); needs the frames' times and headings;
  beside it ``OUT/trajectory_confidence.csv``: ``timestamp,confidence,credible_radius``, one row
  per line of the TUM file. ``--min-confidence C`` keeps only the frames whose confidence is at
  least C in both (a cold start left out of ``evo``'s statistics); ``trajectory.csv`` keeps all;
* ``OUT/trajectory_bag/`` (``--format mcap``): a ROS 2 bag (MCAP storage, :mod:`nightloc.node.record`)
  of the pose with covariance, ``/tf`` (``map -> odom`` once converged and the log's ``odom ->
  base_link``), the belief grid, the prepared image and the true pose, at the frames' times, for
  Foxglove and ``ros2 bag play``; needs the frames' times;
* ``OUT/trajectory.png`` (unless ``--no-figures``; ``--figure-format pdf|svg`` for another
  format): the references, the estimated path with its credible radius, and the true path when
  LOG has poses, with the error and the confidence per frame — then the command also prints the
  median and 90th-percentile distance errors and, from the 10th frame on, the tail: the 95th
  percentile, the share of frames over 1 m and the longest run of such frames.

A map built by a teach run lives in its day drive's odometry frame and a log's ``poses.csv`` in its
survey frame: the true poses are moved into the map's frame by the best rigid 2D fit of the map
onto the day drive's survey (``--survey DAY``, default the map's source traverse; as ``nightloc
evaluate`` does) before any error is computed or drawn, and the command says so; without a survey
it says that the frames differ and reports no errors.

``--learn NEW_MAP`` also writes NEW_MAP (atomically; MAP is never changed): the map plus the
frames this night localized confidently (the night localized forwards, backwards and smoothed),
as further appearances of its places or new places in its gaps
(:mod:`nightloc.experience.learning`, ``[learning]`` in ``--params``); a night that never settles,
or whose frames match none of the map's learned looks (another garden), teaches nothing, and
NEW_MAP is then the map unchanged (the command says so).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np

from ..config import SettingsLayers
from ..errors import DatasetError
from ..experience.learning import LearningParams
from ..figures import add_figure_format_option
from ..io.atomic import OutputSet, check_output_path, output_set
from ..io.trajectory import (
    TRAJECTORY_FORMATS,
    TRAJECTORY_HEADER,
    TUM_CONFIDENCE_FILE,
    confident_frames,
    write_trajectory_csv,
    write_tum,
    write_tum_confidence,
)
from ..io.traverse import Traverse, load_traverse
from ..localization.evaluation import map_alignment
from ..localization.grid_filter import FilterParams
from ..localization.localizer import LocalizationParams, Localizer
from ..localization.tail import FIRST_FRAME, tail_metrics
from ..mapping.reference_map import LOCALIZER_SECTIONS, ReferenceMap
from ..motion.odometry import WHEEL_ODOMETRY_NOISE, NoiseModel, log_noise_model
from ..node.runner import FrameLocalizer
from ..preparation.params import PreparationParams
from .options import (
    add_bag_options,
    add_camera_option,
    add_learn_options,
    add_params_options,
    add_shift_window_option,
    bag_options,
    check_learn_target,
    filter_params_with_window,
    load_reference,
    log_odometry,
    parse_noise,
    parse_shift_window,
    read_settings,
    settings_line,
)
from .wording import duration, refuse_map_as_traverse

__all__ = ["TRAJECTORY_HEADER", "parse_formats", "register", "run"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the sub-command's parser to ``subparsers``."""
    parser = subparsers.add_parser(
        "localize",
        help="localize a recorded night log (frames + odometry) against a map: trajectory.csv and a figure",
        description="Runs the grid Bayes filter over every frame of LOG with its odometry and writes "
        "OUT/trajectory.csv (image,x,y,heading,confidence,credible_radius,ref_index,timestamp), OUT/trajectory.tum "
        "(--format tum: timestamp x y z qx qy qz qw) and OUT/trajectory.png.",
    )
    parser.add_argument("map", type=Path, help="map file (nightloc build-map) or reference traverse (folder or bag)")
    parser.add_argument("log", type=Path, help="the night log: a traverse folder (images/), a video file or a ROS bag")
    parser.add_argument("--out", type=Path, required=True, help="output folder (created with its parents if missing)")
    parser.add_argument(
        "--format",
        default="csv",
        help="csv (trajectory.csv, default), tum (trajectory.tum: timestamp x y z qx qy qz qw, as evo reads, and "
        f"{TUM_CONFIDENCE_FILE}: timestamp,confidence,credible_radius per TUM line), mcap (trajectory_bag/: a ROS 2 "
        "MCAP bag of the pose with covariance, /tf, the belief, the prepared image and the truth, for Foxglove and "
        "ros2 bag play), or several: csv,tum,mcap",
    )
    parser.add_argument(
        "--min-confidence",
        type=float,
        default=0.0,
        help="--format tum: write only the frames whose confidence is at least this, in [0, 1] (default 0: all)",
    )
    parser.add_argument(
        "--odometry",
        help="odometry CSV (default LOG/odometry.csv; a video needs one, keyed by frame), or 'none' for no odometry",
    )
    parser.add_argument(
        "--odometry-noise",
        default=None,
        help="the odometry's noise per frame: a Table III model (0-3), DIST,HEADING standard deviations in "
        "metres and radians, or 'wheel' (4 %% of each step's length, 0.02 rad per step; default: "
        "'wheel' for wheel odometry (forward,left,turn), 1 (0.1 m, 0.02 rad) for map-frame steps)",
    )
    add_params_options(
        parser,
        "[localization], [filter] (over the map's own: build-map --params), [preparation] (the map's, checked) and "
        "[learning] (--learn)",
    )
    add_camera_option(
        parser, "The log's camera: it must be the map's (a reference folder is prepared for it; default panoramic)."
    )
    add_shift_window_option(
        parser,
        "the filter's translation window: +-ROWS rows searched in every comparison (a tilting robot) and, for a "
        "forward camera, +-COLUMNS column offsets over which its headings are told apart (default: [filter] "
        "forward_window and row_window: a quarter of the width, 0 rows); a panoramic map takes 0,ROWS",
    )
    parser.add_argument(
        "--survey",
        type=Path,
        help="a teach-run map (no survey of its own): the day traverse whose poses.csv aligns the map's frame with "
        "the log's poses (default the map's source traverse)",
    )
    parser.add_argument("--threads", type=int, default=1, help="matching threads (default 1, as on a robot)")
    parser.add_argument("--no-figures", action="store_true", help="do not draw trajectory.png")
    add_figure_format_option(parser)
    add_bag_options(parser)
    add_learn_options(parser)
    parser.set_defaults(run=run)


def parse_formats(text: str) -> list[str]:
    """``"csv,tum"`` -> ``["csv", "tum"]``; ValueError naming --format."""
    formats = list(dict.fromkeys(part.strip().lower() for part in str(text).split(",")))
    bad = [f for f in formats if f not in TRAJECTORY_FORMATS]
    if bad or not formats:
        raise ValueError(
            f"--format: {bad[0] if bad else text!r} is not csv, tum or mcap (e.g. --format tum or csv,tum,mcap)"
        )
    return formats


def _load_map(path: Path, preparation, camera: str | None, params_file: SettingsLayers, bag: dict) -> ReferenceMap:
    if not os.path.lexists(path):
        raise DatasetError(
            f"map {path} does not exist (a map file from nightloc build-map or a reference traverse folder)"
        )
    return load_reference(path, preparation, camera, params_file, bag)  # a FIFO, device or link loop is named


def _truth_in_map_frame(log: Traverse, ref_map: ReferenceMap, survey: Path | None) -> tuple[np.ndarray | None, str]:
    """The log's true positions (``(N, 2)`` metres) in the map's frame, or None, and a line saying
    how they were aligned ("" for a surveyed map: one frame). A teach run's map is aligned by
    :func:`nightloc.localization.evaluation.map_alignment` (the rigid fit of the map onto the day
    drive's survey); without a survey there is no truth to compare with, and the line says so."""
    if log.positions is None:
        return None, ""
    truth = np.asarray(log.positions, dtype=np.float64)
    try:
        alignment = map_alignment(ref_map, survey)
    except DatasetError as error:
        if survey is not None:
            raise
        return None, (
            f"no distance errors: {error} (--survey DAY); the trajectory is in the map's frame, the log's poses "
            f"in their survey frame"
        )
    if alignment is None:
        return truth, ""
    return alignment[0].inverse().apply(truth), alignment[1]


def _noise_label(noise: object) -> str:
    """The noise model as the figure's caption names it."""
    if noise == WHEEL_ODOMETRY_NOISE:
        return "wheel"
    if isinstance(noise, NoiseModel):
        return f"{noise.distance_std:g} m, {noise.heading_std:g} rad"
    return str(noise)


class _BagOfTheNight:
    """``--format mcap``: each localized frame into ``OUT/trajectory_bag`` (:mod:`nightloc.node.record`),
    with the log's odometry as ``odom -> base_link`` and its true poses where it has them."""

    def __init__(self, folder: Path, localizer: Localizer, log: Traverse, odometry: list, truth, note: str):
        from ..node.record import NightRecorder, odometry_poses

        self.recorder = NightRecorder(folder / TRAJECTORY_FORMATS["mcap"], localizer.grid, transform_tolerance=1.0)
        self.localizer, self.log, self.truth = localizer, log, truth
        self.odometry = odometry_poses(odometry)
        self.headings = log.headings if not note else None  # a teach run's map: the truth's frame differs

    def write(self, k: int, estimate, prepared: np.ndarray, converged: bool) -> None:
        from ..node.conventions import stamp_of
        from ..node.record import FrameRecord

        assert self.log.timestamps is not None
        truth = None
        if self.truth is not None:
            heading = float(self.headings[k]) if self.headings is not None else 0.0
            truth = (float(self.truth[k][0]), float(self.truth[k][1]), heading if math.isfinite(heading) else 0.0)
        record = FrameRecord(
            stamp_of(float(self.log.timestamps[k])),
            estimate,
            self.odometry[k],
            prepared,
            self.localizer.belief,
            truth,
            converged,
        )
        self.recorder.write(record)

    def close(self) -> None:
        self.recorder.close()


def _check_options(args: argparse.Namespace) -> tuple[int | NoiseModel | None, list[str], tuple[int, int] | None]:
    """The options checked before anything is read: the noise model, the formats, the window."""
    noise = None if args.odometry_noise is None else parse_noise(args.odometry_noise)
    formats = parse_formats(args.format)
    if not 0.0 <= args.min_confidence <= 1.0:
        raise ValueError(f"--min-confidence must be in [0, 1], got {args.min_confidence}")
    if args.min_confidence > 0 and "tum" not in formats:
        raise ValueError(
            "--min-confidence applies to --format tum (trajectory.csv keeps every frame, with its confidence)"
        )
    if args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    return noise, formats, parse_shift_window(args.shift_window)


def _check_outputs(args: argparse.Namespace, inputs: tuple) -> None:
    """OUT (a folder) and --learn's NEW_MAP can be written, and neither is an input."""
    check_output_path(args.out, folder=True, inputs=inputs, parents=True)  # a file in the way fails now
    if args.learn is not None:
        check_learn_target(args.learn, args.map, args.out, inputs, args.overwrite)
    elif args.overwrite:
        raise ValueError("--overwrite replaces the --learn NEW_MAP: give --learn NEW_MAP too")


def _read_log(args: argparse.Namespace, formats: list[str]) -> tuple[Traverse, list, bool]:
    """The log, its odometry (one motion or None per frame) and whether it has none (--odometry none)."""
    refuse_map_as_traverse(args.log, "LOG", "the map comes first: nightloc localize MAP LOG --out OUT")
    log = load_traverse(args.log, **bag_options(args))
    for kind in ("mcap", "tum"):
        if kind in formats and log.timestamps is None:
            raise DatasetError(
                f"--format {kind} needs each frame's time, and the log {log.root} carries none: add a timestamp "
                f"column (seconds) to its odometry.csv or poses.csv, or localize a bag or a video; --format csv "
                f"needs none"
            )
    no_odometry = args.odometry is not None and args.odometry.strip().lower() == "none"
    if no_odometry:
        odometry: list = [None] * len(log)
    else:
        odometry = log_odometry(log, args.odometry, "localize without odometry: --odometry none")
    return log, odometry, no_odometry


def _localize_frames(
    localizer: Localizer, log: Traverse, odometry: list, recorder: _BagOfTheNight | None, learn: bool
) -> tuple[FrameLocalizer, list]:
    """Every frame of the log through the filter (and into the bag): the runner and the estimates."""
    frames = log.frames(progress_desc=f"localizing {log.root.name}")
    runner = FrameLocalizer(localizer, learn=learn)
    estimates = []
    for i, frame in frames:
        prepared = runner.prepare(frame)
        time_s = math.nan if log.timestamps is None else float(log.timestamps[i])
        estimates.append(runner.step(prepared, odometry[i], log.names[i], time_s))
        if recorder is not None:
            recorder.write(i, estimates[-1], prepared, runner.converged)
    if recorder is not None:
        recorder.close()
    return runner, estimates


def _write_trajectories(
    out: OutputSet, formats: list[str], log: Traverse, estimates: list, min_confidence: float, written: list[str]
) -> list[int]:
    """trajectory.csv and the TUM pair (their names added to ``written``); the frames the TUM
    files keep."""
    chosen: list[int] = []
    if "csv" in formats:
        written.append(write_trajectory_csv(out / "trajectory.csv", log.names, estimates, log.timestamps).name)
    if "tum" in formats and log.timestamps is not None:
        chosen = confident_frames(estimates, min_confidence)
        times, confident = [log.timestamps[k] for k in chosen], [estimates[k] for k in chosen]
        written.append(write_tum(out / "trajectory.tum", times, confident).name)
        written.append(write_tum_confidence(out / TUM_CONFIDENCE_FILE, times, confident).name)
    return chosen


def _draw_trajectory(
    folder: Path,
    args: argparse.Namespace,
    log: Traverse,
    ref_map: ReferenceMap,
    localizer: Localizer,
    estimates: list,
    truth: np.ndarray | None,
    alignment_note: str,
    noise_label: str,
    no_odometry: bool,
) -> str:
    """trajectory.png (or the --figure-format) in ``folder``: its name."""
    from ..figures._common import figure_path
    from ..figures.trajectory import trajectory_figure

    source = (
        "none"
        if no_odometry
        else (f"the bag's {(log.bag_topics or {}).get('odometry')}" if log.is_bag else "the log's")
    )
    caption = (
        f"{len(estimates)} frames of {log.root.name} against {len(ref_map)} references; odometry: "
        f"{source}, noise {noise_label}; disks: credible radius "
        f"({localizer.filter_params.credibility:.0%})"
        + (
            "; true path moved into the map's frame by the rigid fit of its survey"
            if truth is not None and alignment_note
            else ""
        )
    )
    figure = figure_path(folder, "trajectory", args.figure_format)
    trajectory_figure(
        ref_map.positions,
        np.array([(e.x, e.y) for e in estimates]),
        truth,
        credible_radius=np.array([e.credible_radius for e in estimates]),
        confidence=np.array([e.confidence for e in estimates]),
        title="nightloc localize: the Bayes filter's trajectory",
        caption=caption,
        path=figure,
        figure_format=args.figure_format,
    )
    return figure.name


def _print_errors(log: Traverse, estimates: list, truth: np.ndarray | None, alignment_note: str) -> None:
    """The alignment's note and, where the log has poses, the distance errors and their tail."""
    if alignment_note:
        print(alignment_note)
    if truth is not None:
        positions = np.array([(e.x, e.y) for e in estimates])
        errors = np.hypot(*(positions - truth).T)
        print(
            f"distance error against {log.root.name}'s poses: median {np.median(errors):.2f} m, "
            f"90th percentile {np.percentile(errors, 90):.2f} m"
        )
        tail = tail_metrics(errors)
        if tail.n:
            print(f"from frame {FIRST_FRAME} on ({tail.n} frames): {tail.line()}")


def run(args: argparse.Namespace) -> int:
    """Runs the sub-command; returns the exit status (errors raise, the CLI prints one line)."""
    noise, formats, window = _check_options(args)
    settings = read_settings(args)
    inputs = (
        args.map,
        args.log,
        args.params,
        args.odometry if args.odometry not in (None, "none") else None,
        args.survey,
    )
    _check_outputs(args, inputs)
    log, odometry, no_odometry = _read_log(args, formats)
    if noise is None:
        noise = log_noise_model(odometry)
    ref_map = _load_map(args.map, settings.section(PreparationParams), args.camera, settings, bag_options(args))
    settings.add(f"the map {args.map}", ref_map.settings, below=True)  # --params and --set win key by key
    params = settings.get(LocalizationParams)
    ref_map.check_frames(log.read(0).shape, f"the log {log.root}", args.camera)
    if "tum" in formats and ref_map.headings is None:
        raise DatasetError(
            f"--format tum needs a heading per frame, and the map {args.map} has no headings (its reference poses "
            f"lack them): use --format csv"
        )
    truth, alignment_note = _truth_in_map_frame(log, ref_map, args.survey)
    filter_params = filter_params_with_window(
        settings.get(FilterParams), window, ref_map.camera, ref_map.images.shape[1:]
    )
    localizer = Localizer(ref_map, params, odometry_noise=noise, filter_params=filter_params, threads=args.threads)
    # Checked and locked before the work; the files appear together at the end, or not at all.
    with output_set(args.out, command="localize", inputs=inputs, parents=True) as out:
        start = time.perf_counter()
        recorder = (
            _BagOfTheNight(out.path, localizer, log, odometry, truth, alignment_note) if "mcap" in formats else None
        )
        runner, estimates = _localize_frames(localizer, log, odometry, recorder, args.learn is not None)
        seconds = time.perf_counter() - start
        written = ["trajectory_bag/"] if recorder is not None else []
        chosen = _write_trajectories(out, formats, log, estimates, args.min_confidence, written)
        if not args.no_figures:
            figure = _draw_trajectory(
                out.path,
                args,
                log,
                ref_map,
                localizer,
                estimates,
                truth,
                alignment_note,
                _noise_label(noise),
                no_odometry,
            )
            written.append(figure)
        if args.learn is not None:
            learned, report = runner.learned_map(str(args.log), settings.section(LearningParams))
            learned.save(args.learn, overwrite=args.overwrite)
    print(settings_line(settings, LOCALIZER_SECTIONS))
    print(
        f"{len(estimates)} frames of {log.root} localized against {len(ref_map)} references in {duration(seconds)} "
        f"({duration(seconds / max(len(estimates), 1))} per frame)"
    )
    last = estimates[-1]
    print(
        f"last frame: ({last.x:.2f}, {last.y:.2f}) m ± {last.credible_radius:.2f} m, heading {last.heading:.2f} rad, "
        f"confidence {last.confidence:.2f}"
    )
    if "tum" in formats and args.min_confidence > 0:
        print(
            f"trajectory.tum: {len(chosen)} of {len(estimates)} frames, those of confidence >= {args.min_confidence:g}"
        )
    _print_errors(log, estimates, truth, alignment_note)
    print(f"wrote {args.out}/" + ", ".join(written))
    if args.learn is not None:
        unchanged = " (the map unchanged)" if learned is ref_map else ""
        print(f"{report.line()}\nwrote {args.learn}{unchanged}")
    return 0
