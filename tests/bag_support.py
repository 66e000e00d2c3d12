"""Bags for the tests, written with rosbags' own writers (no binary bag is committed).

:func:`write_bag` records camera frames on an image topic and, optionally, odometry
(``nav_msgs/Odometry`` or TF) and poses (``geometry_msgs/PoseStamped``), each message at its own
stamp, into a ROS 2 bag (MCAP or sqlite3 storage) or a ROS 1 bag.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from nightloc.io.bag import IMAGE_ENCODINGS

NS = 1_000_000_000


def stamp_ns(seconds: float) -> int:
    """Seconds as integer nanoseconds (rounded)."""
    return round(seconds * NS)


class _Messages:
    def __init__(self, ros1: bool):
        self.ros1 = ros1
        self.store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
        self.types = self.store.types

    def time(self, ns: int):
        return self.types["builtin_interfaces/msg/Time"](sec=ns // NS, nanosec=ns % NS)

    def header(self, ns: int, frame: str):
        header = self.types["std_msgs/msg/Header"]
        if self.ros1:
            return header(seq=0, stamp=self.time(ns), frame_id=frame)
        return header(stamp=self.time(ns), frame_id=frame)

    def serialize(self, message, msgtype: str) -> bytes:
        if self.ros1:
            return self.store.serialize_ros1(message, msgtype)
        return self.store.serialize_cdr(message, msgtype)

    def image(self, ns: int, frame: np.ndarray, encoding: str, padding: int = 0, bigendian: bool = False):
        """A sensor_msgs/Image of a BGR (or grey) uint8 frame in ``encoding`` (any of
        nightloc.io.bag.IMAGE_ENCODINGS, laid out by its channel order and bits: 16 bits hold v * 257,
        an alpha channel 255s)."""
        layout = IMAGE_ENCODINGS[encoding.lower()]
        if layout.order == "mono":
            pixels = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
        else:
            bgr = frame if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
            channel = {
                "b": bgr[:, :, 0],
                "g": bgr[:, :, 1],
                "r": bgr[:, :, 2],
                "a": np.full(bgr.shape[:2], 255, np.uint8),
            }
            pixels = np.stack([channel[c] for c in layout.order], axis=2)
        if layout.bits == 16:
            pixels = (pixels.astype(np.uint16) * 257).astype(">u2" if bigendian else "<u2")
        pixels = np.ascontiguousarray(pixels)
        height, width = pixels.shape[:2]
        row = pixels.reshape(height, -1).view(np.uint8)
        data = np.zeros((height, row.shape[1] + padding), np.uint8)
        data[:, : row.shape[1]] = row
        return self.types["sensor_msgs/msg/Image"](
            header=self.header(ns, "camera"),
            height=height,
            width=width,
            encoding=encoding,
            is_bigendian=int(bigendian),
            step=row.shape[1] + padding,
            data=data.reshape(-1),
        )

    def compressed(self, ns: int, frame: np.ndarray):
        ok, encoded = cv2.imencode(".png", frame)
        assert ok
        return self.types["sensor_msgs/msg/CompressedImage"](
            header=self.header(ns, "camera"), format="png", data=encoded.reshape(-1).astype(np.uint8)
        )

    def quaternion(self, yaw: float):
        return self.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))

    def pose(self, x: float, y: float, yaw: float):
        point = self.types["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0)
        return self.types["geometry_msgs/msg/Pose"](position=point, orientation=self.quaternion(yaw))

    def odometry(self, ns: int, x: float, y: float, yaw: float):
        t = self.types
        covariance = np.zeros(36, dtype=np.float64)
        zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        return t["nav_msgs/msg/Odometry"](
            header=self.header(ns, "odom"),
            child_frame_id="base_link",
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(x, y, yaw), covariance=covariance),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=covariance
            ),
        )

    def pose_stamped(self, ns: int, x: float, y: float, yaw: float):
        return self.types["geometry_msgs/msg/PoseStamped"](header=self.header(ns, "map"), pose=self.pose(x, y, yaw))

    def tf(self, ns: int, x: float, y: float, yaw: float, parent: str = "odom", child: str = "base_link"):
        t = self.types
        transform = t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=0.0), rotation=self.quaternion(yaw)
        )
        stamped = t["geometry_msgs/msg/TransformStamped"](
            header=self.header(ns, parent), child_frame_id=child, transform=transform
        )
        return t["tf2_msgs/msg/TFMessage"](transforms=[stamped])


def write_bag(
    path: Path,
    frames: Sequence[np.ndarray],
    frame_ns: Sequence[int],
    *,
    storage: str = "mcap",
    encoding: str = "bgr8",
    compressed: bool = False,
    image_topic: str = "/camera/image_raw",
    padding: int = 0,
    bigendian: bool = False,
    odometry: np.ndarray | None = None,
    odometry_ns: Sequence[int] | None = None,
    odometry_topic: str = "/odom",
    tf: bool = False,
    tf_frames: tuple[str, str] = ("odom", "base_link"),
    poses: np.ndarray | None = None,
    pose_ns: Sequence[int] | None = None,
    pose_topic: str = "/ground_truth/pose",
    extra_topics: Sequence[tuple[str, str]] = (),
) -> Path:
    """Writes a bag at ``path`` (a folder for ROS 2, a ``.bag`` file for ``storage="ros1"``).

    ``odometry`` and ``poses`` are ``(M, 3)`` x, y, heading at ``odometry_ns`` / ``pose_ns``
    (default: the frames' stamps); each message is recorded at its own stamp. ``extra_topics``:
    (topic, "image" | "odometry" | "pose") topics holding one message each, to make a kind
    ambiguous.
    """
    ros1 = storage == "ros1"
    make = _Messages(ros1)
    messages: list[tuple[int, str, str, object]] = []
    image_type = "sensor_msgs/msg/CompressedImage" if compressed else "sensor_msgs/msg/Image"
    for ns, frame in zip(frame_ns, frames):
        message = make.compressed(ns, frame) if compressed else make.image(ns, frame, encoding, padding, bigendian)
        messages.append((ns, image_topic, image_type, message))
    if odometry is not None:
        times = frame_ns if odometry_ns is None else odometry_ns
        for ns, (x, y, yaw) in zip(times, odometry):
            if tf:
                messages.append((ns, "/tf", "tf2_msgs/msg/TFMessage", make.tf(ns, x, y, yaw, *tf_frames)))
            else:
                messages.append((ns, odometry_topic, "nav_msgs/msg/Odometry", make.odometry(ns, x, y, yaw)))
    if poses is not None:
        times = frame_ns if pose_ns is None else pose_ns
        for ns, (x, y, yaw) in zip(times, poses):
            messages.append((ns, pose_topic, "geometry_msgs/msg/PoseStamped", make.pose_stamped(ns, x, y, yaw)))
    first = min(m[0] for m in messages)
    for topic, kind in extra_topics:
        if kind == "image":
            messages.append((first, topic, image_type, make.image(first, frames[0], "bgr8")))
        elif kind == "odometry":
            messages.append((first, topic, "nav_msgs/msg/Odometry", make.odometry(first, 0.0, 0.0, 0.0)))
        else:
            messages.append((first, topic, "geometry_msgs/msg/PoseStamped", make.pose_stamped(first, 0.0, 0.0, 0.0)))
    messages.sort(key=lambda m: m[0])
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    with writer:
        connections = {}
        for _, topic, msgtype, _ in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=make.store)
        for ns, topic, msgtype, message in messages:
            writer.write(connections[topic], ns, make.serialize(message, msgtype))
    return path
