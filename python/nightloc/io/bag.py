"""ROS bags as traverses: the camera frames of an image topic, with the robot's odometry and
(optionally) poses matched to each frame by time.

Read with `rosbags <https://gitlab.com/ternaris/rosbags>`_ (pure Python; imported only when a
bag is opened): ROS 1 bags (``.bag``), ROS 2 bags (a folder with ``metadata.yaml``, sqlite3 or
MCAP storage) and lone ``.mcap`` / ``.db3`` files.

* **Frames**: ``sensor_msgs/Image`` in an encoding of :data:`IMAGE_ENCODINGS` below (the one
  list; any row stride, either byte order) or ``sensor_msgs/CompressedImage`` (anything
  OpenCV decodes), as BGR or grey, 8 or 16 bit. A frame's time is its header stamp (the bag's
  record time when the stamps are unset).
* **Odometry**: ``nav_msgs/Odometry`` (its pose in its own odom frame) or the TF transform
  ``odom -> base_link`` (or ``base_footprint``) on ``/tf``; interpolated to each frame's time
  and turned into the motion since the previous frame in the robot's frame
  (``forward, left, turn``, what :class:`nightloc.RobotMotion` holds).
* **Poses** (optional): ``geometry_msgs/PoseStamped``, ``PoseWithCovarianceStamped`` or a
  ``nav_msgs/Odometry`` topic named with ``pose_topic``; interpolated to each frame's time: the
  frame's position and heading in the map frame.

Streams are matched by time: positions are interpolated linearly between the two samples around
a frame, headings along the shorter turn. Frames recorded before the odometry (or pose) stream
starts, or after it ends, by more than ``sync_tolerance`` seconds
(:data:`DEFAULT_SYNC_TOLERANCE_S`) are left out with a :class:`~nightloc.errors.DatasetWarning`
naming how many and their times (a camera started before the odometry); any other frame whose
nearest sample is more than ``sync_tolerance`` away (a gap in a stream), or streams that do not
overlap at all, are an error naming how many frames and the times both streams cover. Topics are
chosen automatically when the bag holds one of each kind; otherwise ``image_topic`` /
``odometry_topic`` / ``pose_topic`` name them (the error lists the candidates). Opening a bag
reads its messages once, keeping only times and poses (a few numbers per frame); frames are
decoded one at a time as they are read, so an hour-long bag takes the memory of a few frames.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
import warnings
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, NamedTuple, Union

import cv2
import numpy as np

from ..errors import DatasetError, DatasetWarning
from .kinds import ROS1_BAG, bag_kind

__all__ = [
    "DEFAULT_SYNC_TOLERANCE_S",
    "IMAGE_ENCODINGS",
    "IMAGE_TYPES",
    "ODOMETRY_TYPES",
    "POSE_TYPES",
    "BagFrames",
    "BagLog",
    "ImageEncoding",
    "decode_image",
    "interpolate_poses",
    "load_bag",
    "quaternion_yaw",
    "robot_motions",
    "stamp_seconds",
]

PathLike = Union[str, "os.PathLike[str]"]

#: Largest time (s) between a frame and the nearest odometry or pose sample.
DEFAULT_SYNC_TOLERANCE_S = 0.25

IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
ODOMETRY_TYPES = ("nav_msgs/msg/Odometry",)
POSE_TYPES = ("geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseWithCovarianceStamped")
TF_TYPE = "tf2_msgs/msg/TFMessage"
#: TF frames taken for odometry when ``odometry_topic`` is ``/tf`` (or chosen automatically).
TF_PARENTS = ("odom",)
TF_CHILDREN = ("base_link", "base_footprint")


class ImageEncoding(NamedTuple):
    """How a ``sensor_msgs/Image`` encoding lays out a pixel: its channels in order (``"mono"``,
    ``"bgr"``, ``"rgb"``, ``"bgra"``, ``"rgba"``) and the bits of each (8 or 16)."""

    order: str
    bits: int

    @property
    def channels(self) -> int:
        """Values per pixel."""
        return 1 if self.order == "mono" else len(self.order)

    @property
    def dtype(self) -> type:
        """``numpy.uint8`` or ``numpy.uint16``."""
        return np.uint8 if self.bits == 8 else np.uint16

    @property
    def to_bgr(self) -> int | None:
        """The ``cv2.cvtColor`` code that makes the pixels BGR (alpha dropped), or None (grey or BGR)."""
        return {"rgb": cv2.COLOR_RGB2BGR, "bgra": cv2.COLOR_BGRA2BGR, "rgba": cv2.COLOR_RGBA2BGR}.get(self.order)


#: The ``sensor_msgs/Image`` encodings read (names lowercase, as compared): the one list.
IMAGE_ENCODINGS: dict[str, ImageEncoding] = {
    "mono8": ImageEncoding("mono", 8),
    "8uc1": ImageEncoding("mono", 8),
    "mono16": ImageEncoding("mono", 16),
    "16uc1": ImageEncoding("mono", 16),
    "bgr8": ImageEncoding("bgr", 8),
    "8uc3": ImageEncoding("bgr", 8),
    "rgb8": ImageEncoding("rgb", 8),
    "bgra8": ImageEncoding("bgra", 8),
    "8uc4": ImageEncoding("bgra", 8),
    "rgba8": ImageEncoding("rgba", 8),
    "bgr16": ImageEncoding("bgr", 16),
    "16uc3": ImageEncoding("bgr", 16),
    "rgb16": ImageEncoding("rgb", 16),
    "bgra16": ImageEncoding("bgra", 16),
    "rgba16": ImageEncoding("rgba", 16),
}


def _rosbags() -> Any:
    """The rosbags modules (imported on first use: nothing on the robot's path needs them)."""
    try:
        import rosbags.highlevel
        import rosbags.typesys
    except ImportError as error:  # pragma: no cover - rosbags is a dependency
        raise DatasetError(f"reading ROS bags needs the rosbags package ({error}): pip install rosbags") from None
    return rosbags


# --------------------------------------------------------------------------------------------
# messages


def decode_image(message: Any, msgtype: str, where: str) -> np.ndarray:
    """A ``sensor_msgs/Image`` or ``CompressedImage`` as grey ``(H, W)`` or BGR ``(H, W, 3)``,
    uint8 or uint16. DatasetError names ``where`` for an encoding it cannot read."""
    if msgtype.endswith("CompressedImage"):
        data = np.frombuffer(memoryview(message.data), dtype=np.uint8)
        image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
        if image is None:
            raise DatasetError(f"{where}: the compressed image ({message.format!r}) cannot be decoded")
        if image.ndim == 3 and image.shape[2] == 4:
            image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
        return np.ascontiguousarray(image)
    encoding = str(message.encoding).strip().lower()
    if encoding not in IMAGE_ENCODINGS:
        raise DatasetError(
            f"{where}: image encoding {message.encoding!r} is not read (supported: "
            f"{', '.join(sorted(IMAGE_ENCODINGS))}; or record a sensor_msgs/CompressedImage topic)"
        )
    layout = IMAGE_ENCODINGS[encoding]
    channels, dtype, conversion = layout.channels, layout.dtype, layout.to_bgr
    height, width, step = int(message.height), int(message.width), int(message.step)
    itemsize = np.dtype(dtype).itemsize
    row = width * channels * itemsize
    raw = np.frombuffer(memoryview(message.data), dtype=np.uint8)
    if height < 1 or width < 1 or step < row or raw.size < step * (height - 1) + row:
        raise DatasetError(
            f"{where}: a {width}x{height} {encoding} image needs {row} bytes a row in steps of {step}, but the "
            f"message holds {raw.size} bytes"
        )
    rows = np.lib.stride_tricks.as_strided(raw, shape=(height, row), strides=(step, 1))
    pixels = np.ascontiguousarray(rows).view(np.dtype(dtype).newbyteorder(">" if message.is_bigendian else "<"))
    image = pixels.astype(dtype, copy=False).reshape(height, width, channels)
    if channels == 1:
        return np.ascontiguousarray(image[:, :, 0])
    if conversion is not None:
        return cv2.cvtColor(np.ascontiguousarray(image), conversion)
    return np.ascontiguousarray(image)


def quaternion_yaw(q: Any) -> float:
    """Rotation about z (radians) of a quaternion message."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def stamp_seconds(stamp: Any) -> float:
    """A ``builtin_interfaces/Time`` as seconds, the double nearest the exact decimal."""
    return float(f"{int(stamp.sec)}.{int(stamp.nanosec):09d}")


def _header_seconds(raw: bytes | memoryview, ros2: bool) -> float | None:
    """The header stamp of a raw image message, read without decoding its pixels (a ROS 2 CDR
    message: 4 bytes of encapsulation, then sec and nanosec; ROS 1: seq, secs, nsecs)."""
    data = bytes(raw[:12])
    if len(data) < 12:
        return None
    if ros2:
        order = "<" if data[1] == 1 else ">"
        sec, nanosec = (
            np.frombuffer(data[4:12], dtype=f"{order}i4")[0],
            np.frombuffer(data[8:12], dtype=f"{order}u4")[0],
        )
    else:
        sec, nanosec = np.frombuffer(data[4:8], dtype="<u4")[0], np.frombuffer(data[8:12], dtype="<u4")[0]
    if nanosec >= 1_000_000_000:
        return None
    return float(f"{int(sec)}.{int(nanosec):09d}")


# --------------------------------------------------------------------------------------------
# time matching


def interpolate_poses(
    sample_times: np.ndarray,
    samples: np.ndarray,
    times: np.ndarray,
    tolerance: float,
    stream: str,
    frames: str,
) -> np.ndarray:
    """``samples`` (``(S, 3)``: x, y, heading at ``sample_times`` seconds, ascending)
    interpolated at ``times`` (``(N,)`` seconds): ``(N, 3)``.

    Positions are interpolated linearly, headings along the shorter turn; a time outside the
    samples but within ``tolerance`` of the nearest takes its value. DatasetError (naming
    ``stream`` and ``frames``) when a time is farther than ``tolerance`` from every sample.
    """
    if sample_times.size == 0:
        raise DatasetError(f"{stream} holds no samples")
    after = np.searchsorted(sample_times, times)
    before = np.clip(after - 1, 0, sample_times.size - 1)
    after_clipped = np.clip(after, 0, sample_times.size - 1)
    gap = np.minimum(np.abs(times - sample_times[before]), np.abs(sample_times[after_clipped] - times))
    far = gap > tolerance
    if far.any():
        span = f"{stream} covers {sample_times[0]:.3f}..{sample_times[-1]:.3f} s"
        shown = f"{frames} cover {times[0]:.3f}..{times[-1]:.3f} s"
        if times[-1] < sample_times[0] - tolerance or times[0] > sample_times[-1] + tolerance:
            raise DatasetError(
                f"{frames} and {stream} do not overlap in time: {shown}, {span} (stamped by different clocks?)"
            )
        first = int(np.argmax(far))
        raise DatasetError(
            f"{int(far.sum())} of {times.size} {frames} lie more than {tolerance:g} s from any sample of {stream} "
            f"(the first at {times[first]:.3f} s, {gap[first]:.3f} s away); {shown}, {span}: trim the log, or allow "
            f"a larger gap (--sync-tolerance)"
        )
    unwrapped = np.unwrap(samples[:, 2])
    out = np.empty((times.size, 3))
    for column, values in ((0, samples[:, 0]), (1, samples[:, 1]), (2, unwrapped)):
        out[:, column] = np.interp(times, sample_times, values)
    out[:, 2] = np.pi - np.mod(np.pi - out[:, 2], 2 * np.pi)
    return out


def robot_motions(poses: np.ndarray) -> np.ndarray:
    """``(N, 3)`` motions ``forward, left, turn`` from each pose of ``poses`` (``(N, 3)``: x, y,
    heading in one fixed frame) to the next, in the robot's frame at the earlier pose; row 0 is
    zeros (nothing before the first frame)."""
    motions = np.zeros((len(poses), 3))
    if len(poses) > 1:
        step = np.diff(poses[:, :2], axis=0)
        c, s = np.cos(poses[:-1, 2]), np.sin(poses[:-1, 2])
        motions[1:, 0] = c * step[:, 0] + s * step[:, 1]
        motions[1:, 1] = -s * step[:, 0] + c * step[:, 1]
        turn = np.diff(poses[:, 2])
        motions[1:, 2] = np.pi - np.mod(np.pi - turn, 2 * np.pi)
    return motions


# --------------------------------------------------------------------------------------------
# topics


def _describe(topics: dict[str, Any], names: Iterable[str]) -> str:
    return ", ".join(f"{name} ({topics[name].msgtype}, {topics[name].msgcount} messages)" for name in names)


def _choose(topics: dict[str, Any], types: Sequence[str], given: str | None, kind: str, option: str, bag: Path):
    """The topic of ``kind`` (``given``, or the only one of ``types``), or None when there is none."""
    candidates = sorted(name for name, info in topics.items() if info.msgtype in types)
    if given is not None:
        if given not in topics:
            listing = _describe(topics, sorted(topics)) or "none"
            raise DatasetError(f"{option} {given}: bag {bag} has no such topic (its topics: {listing})")
        if topics[given].msgtype not in types:
            raise DatasetError(
                f"{option} {given}: the topic holds {topics[given].msgtype}, not {' or '.join(types)}"
                + (f" (candidates: {_describe(topics, candidates)})" if candidates else "")
            )
        return given
    if len(candidates) > 1:
        raise DatasetError(
            f"bag {bag} has {len(candidates)} {kind} topics, {_describe(topics, candidates)}: name one with {option}"
        )
    return candidates[0] if candidates else None


def _tf_edge(spec: str) -> tuple[str, str] | None:
    """``/tf`` -> None (the default frames); ``/tf:odom:base_footprint`` -> the two frames."""
    parts = spec.split(":")
    if len(parts) == 1:
        return None
    if len(parts) != 3 or not all(parts[1:]):
        raise DatasetError(f"--odometry-topic {spec!r}: write /tf, or /tf:PARENT:CHILD (e.g. /tf:odom:base_footprint)")
    return parts[1], parts[2]


@dataclasses.dataclass(frozen=True)
class BagFrames:
    """Where a bag traverse's frames are: the bag, the image topic and, per frame, the bag's
    record time (ns) with its rank among the topic's messages recorded at that time, its index
    on the topic; and the topics its odometry and poses came from. Reads frames lazily
    (:meth:`frames`, :meth:`read`); picklable."""

    path: Path
    topic: str
    record_times: tuple[int, ...]
    ranks: tuple[int, ...]
    indices: tuple[int, ...]
    odometry_topic: str | None = None
    pose_topic: str | None = None

    def subset(self, chosen: Sequence[int]) -> BagFrames:
        """The frames at positions ``chosen`` (ascending when read as a stream)."""
        return dataclasses.replace(
            self,
            record_times=tuple(self.record_times[i] for i in chosen),
            ranks=tuple(self.ranks[i] for i in chosen),
            indices=tuple(self.indices[i] for i in chosen),
        )

    def _reader(self) -> Any:
        rosbags = _rosbags()
        store = rosbags.typesys.get_typestore(rosbags.typesys.Stores.LATEST)
        return rosbags.highlevel.AnyReader([self.path], default_typestore=store)

    def frames(self, positions: Iterable[int]) -> Iterator[tuple[int, np.ndarray]]:
        """Decodes the frames at the given traverse positions: in one pass when they are in the
        bag's order, else one at a time."""
        order = list(positions)
        if any(self.indices[b] <= self.indices[a] for a, b in itertools.pairwise(order)):
            for position in order:
                yield position, self.read(position)
            return
        wanted = iter(order)
        target = next(wanted, None)
        if target is None:
            return
        with self._reader() as reader:
            connections = [c for c in reader.connections if c.topic == self.topic]
            index = -1
            for connection, _, raw in reader.messages(connections=connections):
                index += 1
                if self.indices[target] != index:
                    continue
                message = reader.deserialize(raw, connection.msgtype)
                yield target, decode_image(message, connection.msgtype, self._where(target))
                target = next(wanted, None)
                if target is None:
                    return
        if target is not None:
            raise DatasetError(f"bag {self.path}: {self.topic} ended before frame {self.indices[target]} (truncated?)")

    def read(self, position: int) -> np.ndarray:
        """Decodes one frame (found again by its record time)."""
        when = self.record_times[position]
        with self._reader() as reader:
            connections = [c for c in reader.connections if c.topic == self.topic]
            messages = reader.messages(connections=connections, start=when, stop=when + 1)
            for seen, (connection, _, raw) in enumerate(messages):
                if seen == self.ranks[position]:
                    message = reader.deserialize(raw, connection.msgtype)
                    return decode_image(message, connection.msgtype, self._where(position))
        raise DatasetError(f"bag {self.path}: frame {self.indices[position]} of {self.topic} is gone (changed bag?)")

    def _where(self, position: int) -> str:
        return f"bag {self.path}, {self.topic} message {self.indices[position]}"


@dataclasses.dataclass(frozen=True)
class BagLog:
    """What :func:`load_bag` read: per kept frame its name, time, and the interpolated poses and
    odometry motions (or None), with the topics they came from."""

    frames: BagFrames
    names: tuple[str, ...]
    timestamps: np.ndarray
    positions: np.ndarray | None
    headings: np.ndarray | None
    motions: np.ndarray | None
    image_topic: str
    odometry_topic: str | None
    pose_topic: str | None


def load_bag(
    path: PathLike,
    frame_step: int = 1,
    *,
    image_topic: str | None = None,
    odometry_topic: str | None = None,
    pose_topic: str | None = None,
    sync_tolerance: float = DEFAULT_SYNC_TOLERANCE_S,
) -> BagLog:
    """Reads a bag's frame times, odometry and poses (one pass; see the module docstring).

    Raises:
        DatasetError: not a readable bag, no image topic or several without ``image_topic``
            (listing them), an unknown topic, a stream that does not cover the frames' times.
    """
    bag = Path(path)
    if not math.isfinite(sync_tolerance) or sync_tolerance < 0:
        raise ValueError(f"sync tolerance must be a finite number of seconds >= 0, got {sync_tolerance}")
    if bag_kind(bag) == ROS1_BAG and bag.suffix != ".bag":
        raise DatasetError(f"{bag} is a ROS 1 bag; name it with the suffix .bag so that it is read as one")
    rosbags = _rosbags()
    store = rosbags.typesys.get_typestore(rosbags.typesys.Stores.LATEST)
    try:
        reader = rosbags.highlevel.AnyReader([bag], default_typestore=store)
        reader.open()
    except (rosbags.highlevel.AnyReaderError, OSError, ValueError, KeyError) as error:
        raise DatasetError(f"bag {bag} cannot be read: {error}") from None
    try:
        return _index(reader, bag, frame_step, image_topic, odometry_topic, pose_topic, sync_tolerance)
    finally:
        reader.close()


@dataclasses.dataclass
class _Samples:
    """What one pass over a bag's messages gathers: per image message its header stamp (s, None
    when unset), record and rank within the record; the odometry and pose samples ``(t, x, y,
    yaw)``; with TF odometry, the samples per ``(parent, child)`` edge."""

    stamps: list[float | None] = dataclasses.field(default_factory=list)
    records: list[int] = dataclasses.field(default_factory=list)
    ranks: list[int] = dataclasses.field(default_factory=list)
    odometry: list[tuple[float, float, float, float]] = dataclasses.field(default_factory=list)
    poses: list[tuple[float, float, float, float]] = dataclasses.field(default_factory=list)
    tf: dict[tuple[str, str], list[tuple[float, float, float, float]]] = dataclasses.field(default_factory=dict)


def _choose_topics(
    topics: dict, bag: Path, image_topic: str | None, odometry_topic: str | None, pose_topic: str | None
) -> tuple[str, str | None, str | None, bool, tuple[str, str] | None]:
    """The image, pose and odometry topics, whether the odometry is TF, and the TF edge named."""
    image = _choose(topics, IMAGE_TYPES, image_topic, "image", "--image-topic", bag)
    if image is None:
        listing = _describe(topics, sorted(topics)) or "none"
        raise DatasetError(
            f"bag {bag} has no image topic (sensor_msgs/Image or CompressedImage); its topics: {listing}"
        )
    pose = _choose(
        topics, (*POSE_TYPES, *ODOMETRY_TYPES) if pose_topic else POSE_TYPES, pose_topic, "pose", "--pose-topic", bag
    )
    edge: tuple[str, str] | None = None
    tf = False
    odometry: str | None
    if (
        odometry_topic is not None
        and odometry_topic.split(":")[0] in topics
        and topics[odometry_topic.split(":")[0]].msgtype == TF_TYPE
    ):
        tf, edge = True, _tf_edge(odometry_topic)
        odometry = odometry_topic.split(":")[0]
    else:
        free = {name: info for name, info in topics.items() if name != pose}
        odometry = _choose(free, ODOMETRY_TYPES, odometry_topic, "odometry", "--odometry-topic", bag)
        if odometry is None and odometry_topic is None and "/tf" in topics and topics["/tf"].msgtype == TF_TYPE:
            tf, odometry = True, "/tf"
    return image, pose, odometry, tf, edge


def _read_samples(
    reader: Any, bag: Path, image: str, pose: str | None, odometry: str | None, tf: bool, edge: tuple[str, str] | None
) -> _Samples:
    """One pass over the messages of the chosen topics (images: their stamps only)."""
    wanted = {image, odometry, pose} - {None}
    connections = [c for c in reader.connections if c.topic in wanted]
    samples = _Samples()
    last_record, rank = None, 0
    try:
        for connection, record, raw in reader.messages(connections=connections):
            if connection.topic == image:
                rank = rank + 1 if record == last_record else 0
                last_record = record
                samples.stamps.append(_header_seconds(raw, reader.is2))
                samples.records.append(record)
                samples.ranks.append(rank)
                continue
            message = reader.deserialize(raw, connection.msgtype)
            if connection.topic == odometry and tf:
                for transform in message.transforms:
                    key = (transform.header.frame_id.lstrip("/"), transform.child_frame_id.lstrip("/"))
                    if (edge is None and key[0] in TF_PARENTS and key[1] in TF_CHILDREN) or key == edge:
                        t, r = transform.transform.translation, transform.transform.rotation
                        samples.tf.setdefault(key, []).append(
                            (stamp_seconds(transform.header.stamp), t.x, t.y, quaternion_yaw(r))
                        )
                continue
            held = message.pose.pose if hasattr(message.pose, "pose") else message.pose
            sample = (
                stamp_seconds(message.header.stamp),
                held.position.x,
                held.position.y,
                quaternion_yaw(held.orientation),
            )
            if connection.topic == odometry:
                samples.odometry.append(sample)
            if connection.topic == pose:
                samples.poses.append(sample)
    except DatasetError:
        raise
    except Exception as error:  # rosbags raises its own types for damaged bags
        raise DatasetError(f"bag {bag} cannot be read ({type(error).__name__}: {error})") from None
    if not samples.records:
        raise DatasetError(f"bag {bag}: the image topic {image} holds no messages")
    return samples


def _tf_odometry(samples: _Samples, bag: Path, odometry_topic: str | None, edge: tuple[str, str] | None) -> str | None:
    """The TF odometry's name (``/tf:PARENT:CHILD``; None for a /tf without odometry frames), its
    edge's samples made the odometry samples."""
    if len(samples.tf) > 1:
        edges = ", ".join(f"{p} -> {c}" for p, c in sorted(samples.tf))
        raise DatasetError(
            f"bag {bag}: /tf holds several odometry transforms ({edges}): name one with "
            f"--odometry-topic /tf:PARENT:CHILD"
        )
    if not samples.tf:
        if odometry_topic is not None:
            wanted_edge = "{} -> {}".format(*edge) if edge else f"{'/'.join(TF_PARENTS)} -> {'/'.join(TF_CHILDREN)}"
            raise DatasetError(f"bag {bag}: /tf holds no transform {wanted_edge}")
        return None  # a /tf without odometry frames: no odometry
    [(parent, child)] = samples.tf
    samples.odometry = samples.tf[(parent, child)]
    return f"/tf:{parent}:{child}"


def _index(
    reader: Any,
    bag: Path,
    frame_step: int,
    image_topic: str | None,
    odometry_topic: str | None,
    pose_topic: str | None,
    tolerance: float,
) -> BagLog:
    image, pose, odometry, tf, edge = _choose_topics(reader.topics, bag, image_topic, odometry_topic, pose_topic)
    samples = _read_samples(reader, bag, image, pose, odometry, tf, edge)
    records = samples.records
    times = _frame_times(samples.stamps, records, image, bag)
    if tf:
        odometry = _tf_odometry(samples, bag, odometry_topic, edge)
    keep = np.arange(0, len(records), frame_step)
    streams = [(f"the pose topic {pose}", samples.poses)] if pose is not None else []
    if odometry is not None:
        streams.append((f"the odometry {odometry}", samples.odometry))
    keep = _within_streams(keep, times[keep], streams, tolerance, image, bag)
    kept_times = times[keep]
    positions = headings = motions = None
    if pose is not None:
        poses = _matched(samples.poses, kept_times, tolerance, f"the pose topic {pose}", f"the frames of {image}")
        positions, headings = poses[:, :2], poses[:, 2]
    if odometry is not None:
        odom = _matched(samples.odometry, kept_times, tolerance, f"the odometry {odometry}", f"the frames of {image}")
        motions = robot_motions(odom)
    frames = BagFrames(
        bag,
        image,
        tuple(records[i] for i in keep),
        tuple(samples.ranks[i] for i in keep),
        tuple(int(i) for i in keep),
        odometry,
        pose,
    )
    width = max(6, len(str(len(records) - 1)))
    return BagLog(
        frames=frames,
        names=tuple(f"frame_{int(i):0{width}d}" for i in keep),
        timestamps=kept_times,
        positions=positions,
        headings=headings,
        motions=motions,
        image_topic=image,
        odometry_topic=odometry,
        pose_topic=pose,
    )


def _frame_times(stamps: list[float | None], records: list[int], topic: str, bag: Path) -> np.ndarray:
    """Each frame's header stamp (s), or the bag's record times when the stamps are unset."""
    if all(s is not None and s > 0 for s in stamps):
        times = np.array(stamps, dtype=np.float64)
    else:
        times = np.array([float(f"{r // 10**9}.{r % 10**9:09d}") for r in records])
    backwards = np.flatnonzero(np.diff(times) < 0)
    if backwards.size:
        k = int(backwards[0]) + 1
        raise DatasetError(
            f"bag {bag}: the header stamps of {topic} go back in time at message {k} ({times[k]:.6f} s after "
            f"{times[k - 1]:.6f} s); frames must be recorded in time order"
        )
    return times


def _shown_times(times: np.ndarray) -> str:
    """A few frame times (s) in words: all of up to four, else the first two ... the last."""
    if times.size <= 4:
        return ", ".join(f"{t:.3f}" for t in times) + " s"
    return f"{times[0]:.3f}, {times[1]:.3f}, ..., {times[-1]:.3f} s"


def _within_streams(
    keep: np.ndarray, times: np.ndarray, streams: list[tuple[str, list]], tolerance: float, topic: str, bag: Path
) -> np.ndarray:
    """``keep`` (indices of the frames of the image ``topic`` at ``times``, ascending) without the
    frames recorded more than ``tolerance`` before the first or after the last sample of a stream
    (``(words, samples)``, each sample's time first), with a DatasetWarning naming them. When no
    frame lies within every stream, nothing is left out (the matching then names the streams that
    do not overlap)."""
    inside = np.ones(times.size, dtype=bool)
    reasons = []
    for stream, samples in streams:
        if not samples:
            continue
        stamps = np.array([sample[0] for sample in samples], dtype=np.float64)
        first, last = float(stamps.min()), float(stamps.max())
        early, late = times < first - tolerance, times > last + tolerance
        if early.any():
            reasons.append(f"{int(early.sum())} before {stream} starts at {first:.3f} s ({_shown_times(times[early])})")
        if late.any():
            reasons.append(f"{int(late.sum())} after {stream} ends at {last:.3f} s ({_shown_times(times[late])})")
        inside &= ~(early | late)
    if inside.all() or not inside.any():
        return keep
    warnings.warn(
        f"bag {bag}: {int((~inside).sum())} of {times.size} frames of {topic} are skipped, recorded outside the "
        f"streams they need: {'; '.join(reasons)}; the other {int(inside.sum())} frames are kept",
        DatasetWarning,
        stacklevel=4,
    )
    return keep[inside]


def _matched(samples: list, times: np.ndarray, tolerance: float, stream: str, frames: str) -> np.ndarray:
    """The samples ``(t, x, y, heading)`` interpolated at ``times``."""
    if not samples:
        raise DatasetError(f"{stream} holds no messages")
    array = np.array(samples, dtype=np.float64)
    order = np.argsort(array[:, 0], kind="stable")
    array = array[order]
    return interpolate_poses(array[:, 0], array[:, 1:], times, tolerance, stream, frames)
