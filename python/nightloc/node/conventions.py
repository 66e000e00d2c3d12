"""The node's ROS conventions, as numbers: the graph (topics, types, QoS), REP 105's frames, and
the AMCL-style outputs (the pose's covariance, ``map -> odom``, the belief as a grid).

Nothing here imports a middleware: :mod:`nightloc.node.participant` turns :data:`TOPICS` into DDS
readers and writers, :mod:`nightloc.node.build` fills messages from these numbers, and the docs'
table (docs/on_the_robot.md) lists the same rows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..localization.heatmap import HeatGrid
from ..localization.localizer import Estimate

__all__ = [
    "DEFAULT_FRAMES",
    "TOPICS",
    "UNIFORM_HEADING_VARIANCE",
    "BeliefRaster",
    "TopicSpec",
    "compose",
    "invert",
    "map_to_odom",
    "pose_covariance",
    "quaternion",
    "stamp_of",
    "yaw_variance_of",
]


@dataclass(frozen=True)
class TopicSpec:
    """One topic of the node's graph.

    Attributes:
        role: the option that renames it, ``--ROLE-topic``.
        default: the ROS 2 topic name.
        types: the ROS 2 types it carries (the first unless an option picks another).
        incoming: whether the node subscribes (else it publishes).
        reliable: reliable QoS (else best effort); ``transient_local``: late joiners get the last
            ``depth`` messages (else volatile).
        depth: keep-last history depth.
        what: one line for the docs and ``--help``.
    """

    role: str
    default: str
    types: tuple[str, ...]
    incoming: bool
    reliable: bool
    transient_local: bool
    depth: int
    what: str


#: The node's graph, in the order of the docs' table (AMCL's QoS where AMCL has the topic).
TOPICS: tuple[TopicSpec, ...] = (
    TopicSpec(
        "image",
        "/camera/image_raw",
        ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage"),
        True,
        False,
        False,
        5,
        "camera frames (sensor data QoS: the newest frame matters, a lost one does not)",
    ),
    TopicSpec(
        "odometry",
        "/odom",
        ("nav_msgs/msg/Odometry",),
        True,
        True,
        False,
        50,
        "wheel odometry (or TF, see --odometry-topic /tf)",
    ),
    TopicSpec(
        "initialpose",
        "/initialpose",
        ("geometry_msgs/msg/PoseWithCovarianceStamped",),
        True,
        True,
        False,
        1,
        "RViz's 2D Pose Estimate: the belief becomes that Gaussian",
    ),
    TopicSpec(
        "relocalize",
        "/nightloc/relocalize",
        ("std_msgs/msg/Empty",),
        True,
        True,
        False,
        1,
        "global relocalization: the belief becomes uniform",
    ),
    TopicSpec(
        "pose",
        "/nightloc/pose",
        ("geometry_msgs/msg/PoseWithCovarianceStamped",),
        False,
        True,
        True,
        1,
        "the pose with the covariance of x, y and yaw (AMCL's amcl_pose)",
    ),
    TopicSpec(
        "tf",
        "/tf",
        ("tf2_msgs/msg/TFMessage",),
        False,
        True,
        False,
        100,
        "map -> odom while converged, post-dated by --transform-tolerance (and odom -> base_link read from it "
        "with --odometry-topic /tf)",
    ),
    TopicSpec(
        "belief",
        "/nightloc/belief",
        ("nav_msgs/msg/OccupancyGrid",),
        False,
        True,
        True,
        1,
        "the belief over position, 0..100 of its peak, at --belief-rate",
    ),
    TopicSpec(
        "status",
        "/nightloc/status",
        ("diagnostic_msgs/msg/DiagnosticArray",),
        False,
        True,
        False,
        10,
        "confidence, credible radius, converged, frames received, processed and dropped, latency",
    ),
)

#: REP 105's frame names the node uses by default: (map, odom, base).
DEFAULT_FRAMES = ("map", "odom", "base_link")

#: rad^2: the variance of a heading uniform on the circle (what a position-only belief reports).
UNIFORM_HEADING_VARIANCE = math.pi**2 / 3


def quaternion(yaw: float) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` of a rotation by ``yaw`` radians about z."""
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def compose(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float, float]:
    """The 2D pose ``a ∘ b`` (``b`` expressed in ``a``'s frame), each ``(x, y, yaw)``."""
    c, s = math.cos(a[2]), math.sin(a[2])
    yaw = a[2] + b[2]
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], math.atan2(math.sin(yaw), math.cos(yaw)))


def invert(a: tuple[float, float, float]) -> tuple[float, float, float]:
    """The inverse of the 2D pose ``a`` (``(x, y, yaw)``)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


def map_to_odom(
    base_in_map: tuple[float, float, float], base_in_odom: tuple[float, float, float]
) -> tuple[float, float, float]:
    """REP 105's ``map -> odom``: the transform that carries the odometry's pose of the robot onto
    the localizer's, ``map_T_base ∘ (odom_T_base)^-1``."""
    return compose(base_in_map, invert(base_in_odom))


def yaw_variance_of(estimate: Estimate) -> float:
    """rad^2: the estimate's heading variance, or a uniform heading's when the belief has none."""
    value = estimate.heading_variance
    return float(value) if math.isfinite(value) else UNIFORM_HEADING_VARIANCE


def pose_covariance(estimate: Estimate) -> np.ndarray:
    """``(36,)`` float64, the row-major 6 x 6 covariance of ``(x, y, z, roll, pitch, yaw)`` as
    ``PoseWithCovariance`` holds it: x and y from the belief (m^2), yaw from its heading histogram
    (rad^2); z, roll and pitch are not estimated and the cross terms with yaw are left 0 (as AMCL)."""
    covariance = np.zeros((6, 6))
    if estimate.covariance is not None:
        covariance[:2, :2] = np.asarray(estimate.covariance, dtype=np.float64)
    covariance[5, 5] = yaw_variance_of(estimate)
    return covariance.ravel()


def stamp_of(seconds: float) -> tuple[int, int]:
    """``(sec, nanosec)`` of a time in seconds (nanoseconds rounded)."""
    total = round(seconds * 1e9)
    return total // 1_000_000_000, total % 1_000_000_000


class BeliefRaster:
    """The belief over the filter's grid as a ``nav_msgs/OccupancyGrid``: square cells of the
    grid's finer spacing (the grid's cells may be oblong; an occupancy grid has one resolution),
    each taking the grid cell its centre lies in, scaled to 0..100 of the belief's peak.

    Attributes:
        resolution: metres per cell; ``width``, ``height``: cells along x and y.
        origin: ``(x, y)`` of the raster's lower-left corner in the map frame (metres).
    """

    def __init__(self, grid: HeatGrid):
        self.resolution = min(grid.dx, grid.dy)
        span_x, span_y = grid.dx * grid.width, grid.dy * grid.height
        self.width = max(1, round(span_x / self.resolution))
        self.height = max(1, round(span_y / self.resolution))
        self.origin = (grid.x0 - grid.dx / 2, grid.y0 - grid.dy / 2)
        centres_x = (np.arange(self.width) + 0.5) * self.resolution
        centres_y = (np.arange(self.height) + 0.5) * self.resolution
        columns = np.minimum((centres_x / grid.dx).astype(np.int64), grid.width - 1)
        rows = np.minimum((centres_y / grid.dy).astype(np.int64), grid.height - 1)
        self._index = (rows[:, None] * grid.width + columns[None, :]).ravel()

    def values(self, belief: np.ndarray) -> np.ndarray:
        """``(height * width,)`` int8 in 0..100, row 0 the lowest y (as OccupancyGrid): the
        belief ``(grid_height, grid_width)`` over its peak."""
        flat = np.asarray(belief, dtype=np.float64).ravel()
        peak = float(flat.max()) if flat.size else 0.0
        scaled = flat / peak * 100.0 if peak > 0 else np.zeros_like(flat)
        return np.rint(scaled[self._index]).astype(np.int8)
