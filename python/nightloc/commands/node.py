"""``nightloc node``: the localizer live on a robot, a ROS 2 participant over DDS (no ROS install).

    nightloc node MAP [--image-topic T] [--compressed] [--odometry-topic T|/tf|none] [--ROLE-topic T ...]
                      [--map-frame F] [--odom-frame F] [--base-frame F]
                      [--odometry-noise wheel|0-3|DIST,HEADING|covariance] [--sync-tolerance S]
                      [--odometry-wait S] [--converged-confidence C] [--transform-tolerance S]
                      [--belief-rate HZ] [--domain-id N] [--params FILE.toml] [--shift-window COLUMNS,ROWS]
                      [--threads N] [--learn NEW_MAP [--overwrite]] [--record BAG] [--duration S]

It subscribes to the camera, the odometry (``nav_msgs/Odometry``, or TF ``odom -> base_link``),
``initialpose`` and a relocalize topic, and publishes the pose with covariance, ``map -> odom`` while
converged, the belief and a status, with AMCL's conventions (docs/on_the_robot.md; the graph is
:data:`nightloc.node.conventions.TOPICS`). SIGINT or SIGTERM stop it: the frame in hand is
finished, ``--learn NEW_MAP`` is written (atomically; MAP is never changed) and ``--record BAG``
closed. Needs ``pip install "nightloc[ros2]"`` (cyclonedds).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import MissingDependencyError
from ..experience.learning import LearningParams
from ..io.atomic import check_output_path
from ..io.bag import DEFAULT_SYNC_TOLERANCE_S
from ..localization.grid_filter import FilterParams
from ..localization.localizer import LocalizationParams, Localizer
from ..mapping.reference_map import LOCALIZER_SECTIONS
from ..motion.odometry import WHEEL_ODOMETRY_NOISE
from ..node.conventions import DEFAULT_FRAMES, TOPICS
from ..node.runner import DEFAULT_CONVERGED_CONFIDENCE, FrameLocalizer
from ..preparation.params import PreparationParams

if TYPE_CHECKING:
    from ..node.participant import Node, NodeSettings
    from ..node.record import NightRecorder

from .options import (
    add_learn_options,
    add_params_options,
    add_shift_window_option,
    check_learn_target,
    filter_params_with_window,
    load_reference,
    parse_noise,
    parse_shift_window,
    read_settings,
    settings_line,
)

__all__ = ["register", "run"]

INSTALL = 'pip install "nightloc[ros2]"'


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the sub-command's parser to ``subparsers``."""
    parser = subparsers.add_parser(
        "node",
        help="run the localizer live: a ROS 2 node over DDS (AMCL's conventions; needs nightloc[ros2])",
        description="A ROS 2 participant over DDS (cyclonedds, no ROS install): camera frames and odometry in; the "
        "pose with covariance, map -> odom once converged, the belief and a status out. SIGINT/SIGTERM stop it.",
    )
    parser.add_argument("map", type=Path, help="map file (nightloc build-map)")
    topics = parser.add_argument_group("topics (ROS 2 names)")
    for spec in TOPICS:
        extra = ""
        if spec.role == "odometry":
            extra = "; /tf: TF odom -> base_link from the --tf-topic; none: no odometry (every motion unknown)"
        topics.add_argument(
            f"--{spec.role}-topic",
            metavar="TOPIC",
            help=f"{spec.what} ({' or '.join(t.split('/')[-1] for t in spec.types)}; default {spec.default}{extra})",
        )
    topics.add_argument("--compressed", action="store_true", help="the camera topic carries CompressedImage")
    frames = parser.add_argument_group("frames (REP 105)")
    for name, default in zip(("map", "odom", "base"), DEFAULT_FRAMES):
        frames.add_argument(f"--{name}-frame", default=default, help=f"default {default}")
    parser.add_argument(
        "--odometry-noise",
        default="wheel",
        help="the odometry's noise per frame: 'wheel' (default, as localize assumes for a wheel log), a Table III "
        "model 0-3, DIST,HEADING standard deviations, or 'covariance': each step's from the Odometry message's "
        "twist covariance times the step's duration (all zeros: unknown, the wheel model)",
    )
    parser.add_argument(
        "--sync-tolerance",
        type=float,
        default=DEFAULT_SYNC_TOLERANCE_S,
        help=f"largest time (s) between a frame and its nearest odometry sample (default {DEFAULT_SYNC_TOLERANCE_S:g})",
    )
    parser.add_argument(
        "--odometry-wait", type=float, default=0.2, help="seconds a frame waits for odometry at its stamp (0.2)"
    )
    parser.add_argument(
        "--converged-confidence",
        type=float,
        default=DEFAULT_CONVERGED_CONFIDENCE,
        help=f"map -> odom is published while the confidence is at least this (default {DEFAULT_CONVERGED_CONFIDENCE})",
    )
    parser.add_argument(
        "--transform-tolerance", type=float, default=1.0, help="seconds map -> odom is post-dated by (AMCL's; 1.0)"
    )
    parser.add_argument("--belief-rate", type=float, default=1.0, help="belief grids per second (default 1; 0: none)")
    parser.add_argument("--domain-id", type=int, default=None, help="the DDS domain (default $ROS_DOMAIN_ID, else 0)")
    add_params_options(parser, "[localization], [filter] (over the map's own: build-map --params), [learning]")
    add_shift_window_option(parser, "the filter's translation window, as for nightloc localize")
    parser.add_argument("--threads", type=int, default=1, help="matching threads (default 1)")
    add_learn_options(parser)
    parser.add_argument("--record", type=Path, metavar="BAG", help="also write a ROS 2 MCAP bag of the run (folder)")
    parser.add_argument("--duration", type=float, help="stop after this many seconds (default: at SIGINT/SIGTERM)")
    parser.set_defaults(run=run)


def _log(line: str) -> None:
    print(f"nightloc node: {line}", file=sys.stderr, flush=True)


def _domain(value: int | None) -> int:
    if value is None:
        text = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0"
        try:
            value = int(text)
        except ValueError:
            raise ValueError(f"ROS_DOMAIN_ID={text!r} is not a number (0-232)") from None
    if not 0 <= value <= 232:
        raise ValueError(f"--domain-id (or ROS_DOMAIN_ID) must be 0-232 (ROS 2's range), got {value}")
    return value


def _check_options(args: argparse.Namespace) -> None:
    """The numeric options and the output paths, checked before anything is loaded."""
    for name in ("sync_tolerance", "odometry_wait", "transform_tolerance", "belief_rate"):
        value = getattr(args, name)
        if not (value >= 0 and value < float("inf")):
            raise ValueError(f"--{name.replace('_', '-')} must be a finite number >= 0, got {value}")
    if args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    if not 0.0 <= args.converged_confidence <= 1.0:
        raise ValueError(f"--converged-confidence must be in [0, 1], got {args.converged_confidence}")


def _check_outputs(args: argparse.Namespace, inputs: tuple) -> None:
    """--learn's NEW_MAP and --record's folder can be written, and neither is an input."""
    if args.learn is not None:
        check_learn_target(args.learn, args.map, None, inputs, args.overwrite)
    elif args.overwrite:
        raise ValueError("--overwrite replaces the --learn NEW_MAP: give --learn NEW_MAP too")
    if args.record is not None:
        if os.path.lexists(args.record):
            raise ValueError(f"--record {args.record} exists: a recording goes into a new folder (rosbags writes it)")
        check_output_path(args.record, folder=True, overwrite=False, inputs=inputs)


def _node_settings(args: argparse.Namespace, domain: int, covariance_noise: bool) -> NodeSettings:
    """The node's topics (odometry from its topic, from TF or none), frames and timing."""
    from ..node.participant import NodeSettings

    odometry = "topic"
    topic_names = {spec.role: getattr(args, f"{spec.role}_topic") for spec in TOPICS}
    given = (topic_names["odometry"] or "").strip()
    if given.lower() == "none":
        odometry, topic_names["odometry"] = "none", None
    elif given.split(":")[0] in ("/tf", "tf") or (given and given == topic_names["tf"]):
        odometry, topic_names["odometry"] = "tf", None
    return NodeSettings(
        topics={role: name for role, name in topic_names.items() if name},
        compressed=args.compressed,
        odometry=odometry,
        frames=(args.map_frame, args.odom_frame, args.base_frame),
        noise="covariance" if covariance_noise else None,
        sync_tolerance=args.sync_tolerance,
        odometry_wait=args.odometry_wait,
        transform_tolerance=args.transform_tolerance,
        belief_rate=args.belief_rate,
        domain_id=domain,
    )


def _staged_recorder(record: Path, localizer: Localizer, settings: NodeSettings) -> tuple[NightRecorder, Path]:
    """--record's recorder, writing into a staging folder beside ``record`` (renamed when complete)."""
    from ..node.record import NightRecorder

    staging = record.parent / f".{record.name}.partial-{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    recorder = NightRecorder(
        staging / record.name,
        localizer.grid,
        frames=settings.frames,
        topics=settings.topics,
        transform_tolerance=settings.transform_tolerance,
    )
    return recorder, staging


def _spin(node: Node, duration: float | None, record: Path | None, staged: tuple[NightRecorder, Path] | None) -> None:
    """Runs ``node`` until SIGINT/SIGTERM or ``duration`` seconds; the recording is renamed to
    ``record`` when the run ends normally, removed when it fails."""
    stop = threading.Event()

    def on_signal(signum, _frame) -> None:
        stop.set()
        node.stop()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    timer = None
    if duration is not None:
        timer = threading.Timer(max(duration, 0.0), node.stop)
        timer.daemon = True
        timer.start()
    try:
        node.spin()
    except BaseException:
        if staged is not None:  # no half-written bag: the staging goes
            staged[0].close()
            shutil.rmtree(staged[1], ignore_errors=True)
        raise
    else:
        if staged is not None and record is not None:  # the whole run, at once
            staged[0].close()
            os.rename(staged[1] / record.name, record)
            staged[1].rmdir()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if timer is not None:
            timer.cancel()


def run(args: argparse.Namespace) -> int:
    """Runs the node until SIGINT/SIGTERM (or ``--duration``); returns the exit status."""
    try:
        import cyclonedds.domain  # noqa: F401
    except ImportError as error:
        raise MissingDependencyError(f"nightloc node needs cyclonedds ({error}): {INSTALL}") from None
    from ..node.participant import Node

    _check_options(args)
    domain = _domain(args.domain_id)
    covariance_noise = args.odometry_noise.strip().lower() == "covariance"
    noise = WHEEL_ODOMETRY_NOISE if covariance_noise else parse_noise(args.odometry_noise)
    window = parse_shift_window(args.shift_window)
    params = read_settings(args)
    inputs = (args.map, args.params)
    _check_outputs(args, inputs)
    if not args.map.is_file():
        raise ValueError(f"map {args.map} is not a map file (nightloc build-map writes one)")
    ref_map = load_reference(args.map, params.section(PreparationParams))
    params.add(f"the map {args.map}", ref_map.settings, below=True)  # --params and --set win key by key
    filter_params = filter_params_with_window(
        params.get(FilterParams), window, ref_map.camera, ref_map.images.shape[1:]
    )
    localizer = Localizer(
        ref_map,
        params.get(LocalizationParams),
        odometry_noise=noise,
        filter_params=filter_params,
        threads=args.threads,
    )
    _log(settings_line(params, LOCALIZER_SECTIONS))
    runner = FrameLocalizer(localizer, learn=args.learn is not None, converged_confidence=args.converged_confidence)
    settings = _node_settings(args, domain, covariance_noise)
    staged = None if args.record is None else _staged_recorder(args.record, localizer, settings)
    node = Node(runner, settings, _log, None if staged is None else staged[0])
    odometry = settings.odometry
    _log(
        f"ready: domain {domain}, {len(ref_map)} references; frames from {settings.topic('image')}, odometry "
        f"{'none' if odometry == 'none' else settings.topic('tf' if odometry == 'tf' else 'odometry')}; publishing "
        f"{settings.topic('pose')}, {settings.topic('tf')} (map -> odom from confidence "
        f"{args.converged_confidence:g}), {settings.topic('belief')}, {settings.topic('status')}"
    )
    _spin(node, args.duration, args.record, staged)
    stats = node.stats
    _log(
        f"stopped: {stats.received} frames received, {stats.processed} localized, {stats.dropped} dropped (a newer "
        f"frame came first), {stats.skipped} skipped (bad input); latency p50 {1e3 * stats.latency(0.5):.1f} ms, p99 "
        f"{1e3 * stats.latency(0.99):.1f} ms" + (f"; recorded {args.record}" if args.record is not None else "")
    )
    if args.learn is not None:
        learned, report = runner.learned_map(
            f"ROS 2 graph, {settings.topic('image')} (domain {domain})", params.section(LearningParams)
        )
        learned.save(args.learn, overwrite=args.overwrite)
        unchanged = " (the map unchanged)" if learned is ref_map else ""
        _log(f"{report.line()}; wrote {args.learn}{unchanged}")
    return 0
