"""Wire compatibility: every message the node reads or writes serializes, with the node's DDS types
(cyclonedds), to the bytes rosbags' ROS 2 serializer gives for ROS 2 Humble and Jazzy; and the
node reads rosbags' bytes back to the same message."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from nightloc.localization.heatmap import HeatGrid
from nightloc.localization.localizer import Estimate
from nightloc.node import build
from nightloc.node.conventions import TOPICS, BeliefRaster
from nightloc.node.messages import TYPES, dds_topic

STORES = {"humble": Stores.ROS2_HUMBLE, "jazzy": Stores.ROS2_JAZZY}
STAMP = (1_700_000_123, 456_789_012)


def _estimate(heading_variance=0.0123) -> Estimate:
    return Estimate(
        x=1.25, y=-3.5, heading=2.9, ref_index=4, confidence=0.93, frames=12, best_ref=4, score=17.5,
        covariance=((0.04, -0.01), (-0.01, 0.09)), credible_radius=0.4, method="filter",
        heading_variance=heading_variance,
    )  # fmt: skip


def _messages(types):
    """One message of each type the node reads or writes, filled by the node's builders."""
    rng = np.random.default_rng(3)
    raster = BeliefRaster(HeatGrid(0.1, -0.2, 0.3, 0.2, 7, 5))
    odometry = build.odometry(
        types, STAMP, ("odom", "base_link"), (0.5, -0.25, 1.0), np.arange(36.0), np.eye(6).ravel()
    )
    compressed = types["sensor_msgs/msg/CompressedImage"](
        header=build.header(types, STAMP, "camera"), format="png", data=rng.integers(0, 256, 57, dtype=np.uint8)
    )
    return {
        "sensor_msgs/msg/Image": build.image(types, STAMP, "camera", rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)),
        "sensor_msgs/msg/Image (mono8)": build.image(types, STAMP, "camera", rng.integers(0, 256, (3, 5), np.uint8)),
        "sensor_msgs/msg/CompressedImage": compressed,
        "nav_msgs/msg/Odometry": odometry,
        "tf2_msgs/msg/TFMessage": build.tf_message(
            types,
            [
                build.transform_stamped(types, STAMP, "map", "odom", (1.0, 2.0, -0.5)),
                build.transform_stamped(types, (STAMP[0] + 1, 0), "odom", "base_link", (0.1, 0.2, 3.0)),
            ],
        ),
        "geometry_msgs/msg/PoseWithCovarianceStamped": build.pose_with_covariance_stamped(
            types, STAMP, "map", _estimate()
        ),
        "geometry_msgs/msg/PoseStamped": build.pose_stamped(types, STAMP, "map", (3.0, 4.0, 0.25)),
        "std_msgs/msg/Empty": build.empty(types),
        "nav_msgs/msg/OccupancyGrid": build.occupancy_grid(
            types, STAMP, "map", raster, raster.values(rng.uniform(0, 1, (5, 7)))
        ),
        "diagnostic_msgs/msg/DiagnosticArray": build.diagnostic_array(
            types, STAMP, "nightloc", build.WARN, "lost", {"confidence": 0.25, "frames_dropped": 3}
        ),
    }


def test_every_topic_type_is_covered():
    used = {name for spec in TOPICS for name in spec.types}
    assert used <= {name.split(" ")[0] for name in _messages(TYPES)}


@pytest.mark.parametrize("release", sorted(STORES))
def test_bytes_equal_rosbags_serializer(release):
    store = get_typestore(STORES[release])
    ours, theirs = _messages(TYPES), _messages(store.types)
    for name, message in ours.items():
        msgtype = name.split(" ")[0]
        expected = bytes(store.serialize_cdr(theirs[name], msgtype))
        assert bytes(message.serialize()) == expected, name
        back = TYPES[msgtype].deserialize(expected)  # the node reads what a ROS 2 node writes
        assert back == message, name


@pytest.mark.parametrize("release", sorted(STORES))
def test_definitions_match_the_typestore(release):
    # field names in order and the DDS type names, for every type (nested ones too)
    store = get_typestore(STORES[release])
    for msgtype, cls in TYPES.items():
        package, _, name = msgtype.split("/")
        assert cls.__idl_typename__ == f"{package}::msg::dds_::{name}_"
        assert [f.name for f in dataclasses.fields(cls)] == [f[0] for f in store.fielddefs[msgtype][1]], msgtype


def test_pose_covariance_layout():
    message = _messages(TYPES)["geometry_msgs/msg/PoseWithCovarianceStamped"]
    covariance = np.array(message.pose.covariance).reshape(6, 6)
    np.testing.assert_array_equal(covariance[:2, :2], [[0.04, -0.01], [-0.01, 0.09]])
    assert covariance[5, 5] == 0.0123
    assert np.count_nonzero(covariance) == 5
    q = message.pose.pose.orientation
    assert 2 * math.atan2(q.z, q.w) == pytest.approx(2.9)
    # a position-only belief: a uniform heading's variance, pi^2 / 3
    lost = build.pose_with_covariance_stamped(TYPES, STAMP, "map", _estimate(math.nan))
    assert lost.pose.covariance[35] == pytest.approx(math.pi**2 / 3)


def test_dds_topic_names():
    assert dds_topic("/camera/image_raw") == "rt/camera/image_raw"
    assert dds_topic("tf") == "rt/tf"
