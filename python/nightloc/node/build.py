"""ROS 2 messages filled from the node's numbers, for any set of message classes with ROS's field
names: the node's DDS types (:data:`nightloc.node.messages.TYPES`, live) or rosbags' typestore
(``get_typestore(...).types``, recordings). Arrays are given as numpy arrays (what rosbags takes;
the DDS types convert them).

``types`` is a mapping from a ROS 2 type name (``geometry_msgs/msg/Pose``) to its class; stamps
are ``(sec, nanosec)``; poses ``(x, y, yaw)`` in metres and radians.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from ..localization.localizer import Estimate
from .conventions import BeliefRaster, pose_covariance, quaternion

__all__ = [
    "Stamp",
    "diagnostic_array",
    "empty",
    "header",
    "image",
    "occupancy_grid",
    "odometry",
    "pose",
    "pose_stamped",
    "pose_with_covariance_stamped",
    "tf_message",
    "transform_stamped",
]

Types = Mapping[str, Any]
Stamp = tuple[int, int]
Pose2D = tuple[float, float, float]

#: DiagnosticStatus levels: OK, WARN, ERROR.
OK, WARN, ERROR = 0, 1, 2


def header(types: Types, stamp: Stamp, frame: str) -> Any:
    time = types["builtin_interfaces/msg/Time"](sec=int(stamp[0]), nanosec=int(stamp[1]))
    return types["std_msgs/msg/Header"](stamp=time, frame_id=frame)


def pose(types: Types, xyyaw: Pose2D) -> Any:
    qx, qy, qz, qw = quaternion(float(xyyaw[2]))
    return types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](x=float(xyyaw[0]), y=float(xyyaw[1]), z=0.0),
        orientation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
    )


def pose_with_covariance_stamped(types: Types, stamp: Stamp, frame: str, estimate: Estimate) -> Any:
    """The estimate as AMCL publishes ``amcl_pose``: its position and heading (0 where the map has
    no headings) with :func:`~nightloc.node.conventions.pose_covariance`."""
    heading = estimate.heading if np.isfinite(estimate.heading) else 0.0
    return types["geometry_msgs/msg/PoseWithCovarianceStamped"](
        header=header(types, stamp, frame),
        pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=pose(types, (estimate.x, estimate.y, heading)), covariance=pose_covariance(estimate)
        ),
    )


def pose_stamped(types: Types, stamp: Stamp, frame: str, xyyaw: Pose2D) -> Any:
    return types["geometry_msgs/msg/PoseStamped"](header=header(types, stamp, frame), pose=pose(types, xyyaw))


def transform_stamped(types: Types, stamp: Stamp, parent: str, child: str, xyyaw: Pose2D) -> Any:
    """``parent -> child``: the child frame's pose in the parent's."""
    qx, qy, qz, qw = quaternion(float(xyyaw[2]))
    transform = types["geometry_msgs/msg/Transform"](
        translation=types["geometry_msgs/msg/Vector3"](x=float(xyyaw[0]), y=float(xyyaw[1]), z=0.0),
        rotation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
    )
    return types["geometry_msgs/msg/TransformStamped"](
        header=header(types, stamp, parent), child_frame_id=child, transform=transform
    )


def tf_message(types: Types, transforms: Iterable[Any]) -> Any:
    return types["tf2_msgs/msg/TFMessage"](transforms=list(transforms))


def odometry(
    types: Types,
    stamp: Stamp,
    frames: tuple[str, str],
    xyyaw: Pose2D,
    pose_cov: np.ndarray | None = None,
    twist_cov: np.ndarray | None = None,
) -> Any:
    """``nav_msgs/Odometry``: the base frame's pose in the odom frame (``frames``: odom, base), no
    twist; covariances ``(36,)`` (default zeros: unknown)."""
    zero = types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    return types["nav_msgs/msg/Odometry"](
        header=header(types, stamp, frames[0]),
        child_frame_id=frames[1],
        pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=pose(types, xyyaw), covariance=np.zeros(36) if pose_cov is None else np.asarray(pose_cov, np.float64)
        ),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](
            twist=types["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
            covariance=np.zeros(36) if twist_cov is None else np.asarray(twist_cov, np.float64),
        ),
    )


def image(types: Types, stamp: Stamp, frame: str, pixels: np.ndarray) -> Any:
    """``sensor_msgs/Image`` of a ``(H, W)`` uint8 (``mono8``) or ``(H, W, 3)`` uint8 (``bgr8``) array."""
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    height, width = pixels.shape[:2]
    channels = 1 if pixels.ndim == 2 else pixels.shape[2]
    return types["sensor_msgs/msg/Image"](
        header=header(types, stamp, frame),
        height=height,
        width=width,
        encoding="mono8" if channels == 1 else "bgr8",
        is_bigendian=0,
        step=width * channels,
        data=pixels.reshape(-1),
    )


def occupancy_grid(types: Types, stamp: Stamp, frame: str, raster: BeliefRaster, values: np.ndarray) -> Any:
    """The belief as ``nav_msgs/OccupancyGrid`` (:class:`~nightloc.node.conventions.BeliefRaster`)."""
    info = types["nav_msgs/msg/MapMetaData"](
        map_load_time=types["builtin_interfaces/msg/Time"](sec=int(stamp[0]), nanosec=int(stamp[1])),
        resolution=float(np.float32(raster.resolution)),  # float32 on the wire
        width=raster.width,
        height=raster.height,
        origin=pose(types, (raster.origin[0], raster.origin[1], 0.0)),
    )
    return types["nav_msgs/msg/OccupancyGrid"](
        header=header(types, stamp, frame), info=info, data=np.asarray(values, dtype=np.int8)
    )


def diagnostic_array(types: Types, stamp: Stamp, name: str, level: int, message: str, values: Mapping[str, Any]) -> Any:
    """One ``DiagnosticStatus`` (``level`` OK, WARN or ERROR) in a ``DiagnosticArray``."""
    pairs = [types["diagnostic_msgs/msg/KeyValue"](key=str(k), value=str(v)) for k, v in values.items()]
    status = types["diagnostic_msgs/msg/DiagnosticStatus"](
        level=int(level), name=name, message=message, hardware_id="", values=pairs
    )
    return types["diagnostic_msgs/msg/DiagnosticArray"](header=header(types, stamp, ""), status=[status])


def empty(types: Types) -> Any:
    return types["std_msgs/msg/Empty"](structure_needs_at_least_one_member=0)
