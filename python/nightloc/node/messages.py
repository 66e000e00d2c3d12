"""The ROS 2 messages the node reads and writes, as DDS types (``cyclonedds`` IDL structs).

(No ``from __future__ import annotations`` here: cyclonedds reads the field types at run time.)

Each class carries its ROS 2 type's DDS name (``sensor_msgs::msg::dds_::Image_``) and its fields
in the ROS order with the ROS types, so that its CDR bytes are a ROS 2 node's
(``tests/node/test_wire.py`` checks them against rosbags' serializer for Humble and Jazzy).
``uint8[]`` fields (the images' pixels) are declared ``sequence<uint8>`` as ROS does and hold
``bytes``: their serializer is swapped for one that copies the run of bytes at once (cyclonedds
would pack and unpack them one Python int at a time, milliseconds a frame). A numpy array given
for an array or sequence field is converted on construction, so the message builders of
:mod:`nightloc.node.build` fill these classes and rosbags' alike.

:data:`TYPES` maps each ROS 2 type name (``sensor_msgs/msg/Image``) to its class.
"""

from dataclasses import dataclass, field, fields

import numpy as np
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types as t
from cyclonedds.idl._machinery import PlainCdrV2SequenceOfPrimitiveMachine

__all__ = ["TYPES", "dds_topic"]


class _Message:
    """Converts numpy arrays given for array and sequence fields: ``uint8[]`` fields (those of
    :data:`_OCTET_FIELDS`) take their bytes, the others a list of Python numbers."""

    def __post_init__(self) -> None:
        octets = _OCTET_FIELDS.get(type(self), ())
        for f in fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            if f.name in octets and not isinstance(value, bytes):
                setattr(self, f.name, np.ascontiguousarray(value, dtype=np.uint8).tobytes())
            elif isinstance(value, np.ndarray):
                setattr(self, f.name, value.tolist())


class _OctetRun(PlainCdrV2SequenceOfPrimitiveMachine):
    """``sequence<uint8>`` as ``bytes``: the length, then the bytes in one copy (the same wire
    bytes as cyclonedds' own machine for the type)."""

    def serialize(self, buffer, value, *args, **kwargs):
        buffer.align(4)
        buffer.write("I", 4, len(value))
        if len(value):
            buffer.write_bytes(value)

    def deserialize(self, buffer, *args, **kwargs):
        buffer.align(4)
        return buffer.read_bytes(buffer.read("I", 4))


def _octets(cls: type, *names: str) -> None:
    """Gives ``cls``' ``uint8[]`` fields ``names`` the :class:`_OctetRun` serializer."""
    idl = cls.__idl__  # type: ignore[attr-defined]
    idl.populate()
    for machine in (idl.v1_machine, idl.v2_machine):
        for name in names:
            machine.members_machines[name] = _OctetRun(t.uint8)
    _OCTET_FIELDS[cls] = names


_OCTET_FIELDS: dict[type, tuple[str, ...]] = {}


@dataclass
class Time(IdlStruct, _Message, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: t.int32 = 0
    nanosec: t.uint32 = 0


@dataclass
class Header(IdlStruct, _Message, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class Empty(IdlStruct, _Message, typename="std_msgs::msg::dds_::Empty_"):
    structure_needs_at_least_one_member: t.uint8 = 0


@dataclass
class Image(IdlStruct, _Message, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header = field(default_factory=Header)
    height: t.uint32 = 0
    width: t.uint32 = 0
    encoding: str = ""
    is_bigendian: t.uint8 = 0
    step: t.uint32 = 0
    data: t.sequence[t.uint8] = b""


@dataclass
class CompressedImage(IdlStruct, _Message, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    header: Header = field(default_factory=Header)
    format: str = ""
    data: t.sequence[t.uint8] = b""


@dataclass
class Point(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::Point_"):
    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0


@dataclass
class Vector3(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0


@dataclass
class Quaternion(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0
    w: t.float64 = 1.0


@dataclass
class Pose(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseWithCovariance(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: t.array[t.float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class PoseWithCovarianceStamped(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"):
    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass
class PoseStamped(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass
class Twist(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistWithCovariance(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: t.array[t.float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Transform(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, _Message, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, _Message, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: t.sequence[TransformStamped] = field(default_factory=list)


@dataclass
class Odometry(IdlStruct, _Message, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
class MapMetaData(IdlStruct, _Message, typename="nav_msgs::msg::dds_::MapMetaData_"):
    map_load_time: Time = field(default_factory=Time)
    resolution: t.float32 = 0.0
    width: t.uint32 = 0
    height: t.uint32 = 0
    origin: Pose = field(default_factory=Pose)


@dataclass
class OccupancyGrid(IdlStruct, _Message, typename="nav_msgs::msg::dds_::OccupancyGrid_"):
    header: Header = field(default_factory=Header)
    info: MapMetaData = field(default_factory=MapMetaData)
    data: t.sequence[t.int8] = field(default_factory=list)


@dataclass
class KeyValue(IdlStruct, _Message, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str = ""
    value: str = ""


@dataclass
class DiagnosticStatus(IdlStruct, _Message, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: t.uint8 = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: t.sequence[KeyValue] = field(default_factory=list)


@dataclass
class DiagnosticArray(IdlStruct, _Message, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header = field(default_factory=Header)
    status: t.sequence[DiagnosticStatus] = field(default_factory=list)


_octets(Image, "data")
_octets(CompressedImage, "data")

#: ROS 2 type name -> the DDS type.
TYPES: dict[str, type] = {
    "builtin_interfaces/msg/Time": Time,
    "std_msgs/msg/Header": Header,
    "std_msgs/msg/Empty": Empty,
    "sensor_msgs/msg/Image": Image,
    "sensor_msgs/msg/CompressedImage": CompressedImage,
    "geometry_msgs/msg/Point": Point,
    "geometry_msgs/msg/Vector3": Vector3,
    "geometry_msgs/msg/Quaternion": Quaternion,
    "geometry_msgs/msg/Pose": Pose,
    "geometry_msgs/msg/PoseWithCovariance": PoseWithCovariance,
    "geometry_msgs/msg/PoseWithCovarianceStamped": PoseWithCovarianceStamped,
    "geometry_msgs/msg/PoseStamped": PoseStamped,
    "geometry_msgs/msg/Twist": Twist,
    "geometry_msgs/msg/TwistWithCovariance": TwistWithCovariance,
    "geometry_msgs/msg/Transform": Transform,
    "geometry_msgs/msg/TransformStamped": TransformStamped,
    "tf2_msgs/msg/TFMessage": TFMessage,
    "nav_msgs/msg/Odometry": Odometry,
    "nav_msgs/msg/MapMetaData": MapMetaData,
    "nav_msgs/msg/OccupancyGrid": OccupancyGrid,
    "diagnostic_msgs/msg/KeyValue": KeyValue,
    "diagnostic_msgs/msg/DiagnosticStatus": DiagnosticStatus,
    "diagnostic_msgs/msg/DiagnosticArray": DiagnosticArray,
}


def dds_topic(ros_topic: str) -> str:
    """The DDS topic of a ROS 2 topic: ``/camera/image_raw`` -> ``rt/camera/image_raw``."""
    return "rt/" + ros_topic.lstrip("/")
