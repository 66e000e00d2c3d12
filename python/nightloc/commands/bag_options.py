"""The options of every command that reads a traverse from a ROS bag: which topics, and how far
apart a frame and its odometry or pose sample may be."""

from __future__ import annotations

import argparse
import math
from typing import Any

from ..io.bag import DEFAULT_SYNC_TOLERANCE_S

__all__ = ["add_bag_options", "bag_options"]


def add_bag_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--image-topic``, ``--odometry-topic``, ``--pose-topic`` and ``--sync-tolerance``."""
    group = parser.add_argument_group(
        "ROS bags",
        "a traverse may be a ROS 1 or ROS 2 bag; its topics are found by type when there is one of each kind",
    )
    group.add_argument("--image-topic", help="sensor_msgs/Image or CompressedImage topic of the camera")
    group.add_argument(
        "--odometry-topic",
        help="nav_msgs/Odometry topic of the wheel odometry, or /tf (odom -> base_link), or /tf:PARENT:CHILD",
    )
    group.add_argument("--pose-topic", help="PoseStamped, PoseWithCovarianceStamped or Odometry topic of true poses")
    group.add_argument(
        "--sync-tolerance",
        type=float,
        default=DEFAULT_SYNC_TOLERANCE_S,
        help=f"largest time (s) between a frame and its nearest odometry or pose message "
        f"(default {DEFAULT_SYNC_TOLERANCE_S:g})",
    )


def bag_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword arguments of :func:`nightloc.load_traverse` that the options give (only
    those set, so that folders and videos are not told about topics)."""
    if not (math.isfinite(args.sync_tolerance) and args.sync_tolerance >= 0):
        raise ValueError(f"--sync-tolerance must be a finite number of seconds >= 0, got {args.sync_tolerance}")
    options: dict[str, Any] = {
        name: getattr(args, name)
        for name in ("image_topic", "odometry_topic", "pose_topic")
        if getattr(args, name) is not None
    }
    if args.sync_tolerance != DEFAULT_SYNC_TOLERANCE_S:
        options["sync_tolerance"] = args.sync_tolerance
    return options
