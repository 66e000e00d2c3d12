"""A localized night as a ROS 2 bag (MCAP storage, written with rosbags): what ``nightloc localize
--format mcap`` and ``nightloc node --record`` write, for Foxglove and ``ros2 bag play``.

Per localized frame, at the frame's stamp:

* the pose topic (``/nightloc/pose``): ``PoseWithCovarianceStamped`` in the map frame;
* ``/tf``: the odometry's ``odom -> base_link`` at the frame's stamp and, while converged,
  ``map -> odom`` post-dated by the transform tolerance (as the node publishes it);
* the belief topic (``/nightloc/belief``): ``OccupancyGrid`` (every frame);
* ``/nightloc/prepared``: the prepared image (``mono8``, 48 x 24 for the paper's parameters);
* ``/nightloc/truth``: ``PoseStamped``, the log's true pose in the map frame, where it has one.

Message types are rosbags' ROS 2 Humble definitions (Jazzy's are the same for these types).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..localization.heatmap import HeatGrid
from ..localization.localizer import Estimate
from ..motion.odometry import MapDisplacement, RobotMotion
from . import build
from .conventions import DEFAULT_FRAMES, TOPICS, BeliefRaster, compose, map_to_odom

__all__ = ["PREPARED_TOPIC", "TRUTH_TOPIC", "FrameRecord", "NightRecorder", "odometry_poses", "recorded_topics"]

#: Topics only recordings carry.
PREPARED_TOPIC = "/nightloc/prepared"
TRUTH_TOPIC = "/nightloc/truth"

Pose2D = tuple[float, float, float]


@dataclass(frozen=True)
class FrameRecord:
    """What one localized frame gave.

    Attributes:
        stamp: the frame's header stamp ``(sec, nanosec)``.
        estimate: the localizer's answer.
        odometry: the base frame's pose in the odom frame at the stamp ``(x, y, yaw)``, or None.
        prepared: ``(Ry, Rx)`` uint8, the frame as the map's preparation made it.
        belief: ``(grid_height, grid_width)`` the belief over position, or None.
        truth: the log's true pose in the map frame, or None.
        converged: whether ``map -> odom`` is published for this frame.
    """

    stamp: tuple[int, int]
    estimate: Estimate
    odometry: Pose2D | None
    prepared: np.ndarray
    belief: np.ndarray | None
    truth: Pose2D | None
    converged: bool


def recorded_topics(topics: dict[str, str] | None = None) -> dict[str, str]:
    """Topic name -> ROS 2 type of a recording (``topics``: role -> name, the node's renamings)."""
    names = {spec.role: spec.default for spec in TOPICS} | (topics or {})
    return {
        names["pose"]: "geometry_msgs/msg/PoseWithCovarianceStamped",
        names["tf"]: "tf2_msgs/msg/TFMessage",
        names["belief"]: "nav_msgs/msg/OccupancyGrid",
        PREPARED_TOPIC: "sensor_msgs/msg/Image",
        TRUTH_TOPIC: "geometry_msgs/msg/PoseStamped",
    }


def odometry_poses(motions: list) -> list[Pose2D]:
    """A log's odometry as poses of the base frame in an odom frame that starts at the first
    frame: each :class:`RobotMotion` composed onto the pose before, a :class:`MapDisplacement`
    added (the odom frame's axes then the map's), an unknown motion (None) no motion."""
    pose: Pose2D = (0.0, 0.0, 0.0)
    poses = []
    for k, motion in enumerate(motions):
        if k and isinstance(motion, RobotMotion):
            pose = compose(pose, (motion.forward, motion.left, motion.turn))
        elif k and isinstance(motion, MapDisplacement):
            pose = (pose[0] + motion.dx, pose[1] + motion.dy, pose[2])
        poses.append(pose)
    return poses


def _ns(stamp: tuple[int, int]) -> int:
    return int(stamp[0]) * 1_000_000_000 + int(stamp[1])


class NightRecorder:
    """Writes :class:`FrameRecord` s into a new ROS 2 bag folder ``path`` (MCAP storage).

    Args:
        path: the bag folder (must not exist; rosbags creates it).
        grid: the filter's grid (the belief's raster).
        frames: the map, odom and base frame names.
        topics: role -> topic name (the node's renamings; default :data:`TOPICS`' names).
        transform_tolerance: seconds ``map -> odom`` is post-dated by.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        grid: HeatGrid,
        *,
        frames: tuple[str, str, str] = DEFAULT_FRAMES,
        topics: dict[str, str] | None = None,
        transform_tolerance: float = 0.0,
    ):
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        self.store = get_typestore(Stores.ROS2_HUMBLE)
        self.types = self.store.types
        self.frames = frames
        self.raster = BeliefRaster(grid)
        self.tolerance_ns = round(transform_tolerance * 1e9)
        self.path = Path(path)
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._connections: dict[str, tuple[Any, str]] = {}
        for topic, msgtype in recorded_topics(topics).items():
            self._connections[msgtype] = (self._writer.add_connection(topic, msgtype, typestore=self.store), topic)
        self.frames_written = 0

    def _write(self, msgtype: str, message: Any, stamp_ns: int) -> None:
        connection, _ = self._connections[msgtype]
        self._writer.write(connection, stamp_ns, bytes(self.store.serialize_cdr(message, msgtype)))

    def write(self, record: FrameRecord) -> None:
        """Writes one frame's messages (see the module docstring)."""
        types, (map_frame, odom_frame, base_frame) = self.types, self.frames
        stamp, ns = record.stamp, _ns(record.stamp)
        estimate = record.estimate
        self._write(
            "geometry_msgs/msg/PoseWithCovarianceStamped",
            build.pose_with_covariance_stamped(types, stamp, map_frame, estimate),
            ns,
        )
        transforms = []
        if record.odometry is not None:
            transforms.append(build.transform_stamped(types, stamp, odom_frame, base_frame, record.odometry))
            heading = estimate.heading if math.isfinite(estimate.heading) else 0.0
            if record.converged:
                later = divmod(ns + self.tolerance_ns, 1_000_000_000)
                correction = map_to_odom((estimate.x, estimate.y, heading), record.odometry)
                transforms.append(build.transform_stamped(types, later, map_frame, odom_frame, correction))
        if transforms:
            self._write("tf2_msgs/msg/TFMessage", build.tf_message(types, transforms), ns)
        if record.belief is not None:
            grid = build.occupancy_grid(types, stamp, map_frame, self.raster, self.raster.values(record.belief))
            self._write("nav_msgs/msg/OccupancyGrid", grid, ns)
        self._write("sensor_msgs/msg/Image", build.image(types, stamp, "nightloc_prepared", record.prepared), ns)
        if record.truth is not None:
            self._write("geometry_msgs/msg/PoseStamped", build.pose_stamped(types, stamp, map_frame, record.truth), ns)
        self.frames_written += 1

    def close(self) -> None:
        """Finishes the bag (its metadata.yaml and the MCAP summary)."""
        self._writer.close()

    def __enter__(self) -> NightRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
