"""Odometry for 2D sequence matching: motions between frames, and simulated odometry with noise.

The sequence matcher (:mod:`nightloc.localization.sequence`) needs, for every earlier frame of the sequence,
its displacement to the current frame *in the map frame*. A robot reports its motion in one of
two forms, passed to :meth:`nightloc.Localizer.update`:

* :class:`MapDisplacement` ``(dx, dy)``: metres in the map frame since the previous frame (a
  plain ``(dx, dy)`` tuple or array means the same). This is what the paper's evaluation uses.
* :class:`RobotMotion` ``(forward, left, turn)``: wheel-encoder style, in the robot's own frame
  at the previous frame (metres ahead, metres to the left, radians turned counter-clockwise).
  The localizer rotates it into the map frame with its heading estimate (beyond the paper), see
  :func:`robot_steps_to_map`.

Simulated odometry from ground-truth poses uses the paper's Table III noise models
(:data:`NOISE_MODELS`): zero-mean Gaussian noise per step on the distance travelled and on the
heading, drawn from a seeded ``numpy.random.Generator``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Union

import numpy as np

from .. import _core
from .._validate import coordinates, metres, not_masked

if TYPE_CHECKING:
    from ..io.traverse import Traverse

__all__ = [
    "NOISE_MODELS",
    "WHEEL_ODOMETRY_NOISE",
    "MapDisplacement",
    "NoiseModel",
    "RobotMotion",
    "as_motion",
    "compose_motions",
    "log_noise_model",
    "noise_model",
    "read_odometry",
    "reverse_motion",
    "robot_steps_to_map",
    "simulate_map_odometry",
    "simulate_robot_odometry",
    "traverse_odometry",
    "true_map_steps",
    "true_robot_motions",
    "wrap_angle",
]


def wrap_angle(angle: float | np.ndarray) -> float | np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    if isinstance(angle, float):  # the per-frame fast path
        return math.pi - (math.pi - angle) % (2 * math.pi)
    wrapped = np.pi - np.mod(np.pi - np.asarray(angle, dtype=np.float64), 2 * np.pi)
    return float(wrapped) if np.ndim(wrapped) == 0 else wrapped


def _finite(value: object, name: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {number}")
    if name != "turn":
        metres(number, name)
    return number


@dataclass(frozen=True)
class MapDisplacement:
    """Motion since the previous frame in the map frame.

    Attributes:
        dx, dy: metres along the map's x and y axes.
    """

    dx: float
    dy: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dx", _finite(self.dx, "dx"))
        object.__setattr__(self, "dy", _finite(self.dy, "dy"))


@dataclass(frozen=True)
class RobotMotion:
    """Motion since the previous frame in the robot's frame at the previous frame.

    Attributes:
        forward: metres along the robot's heading at the previous frame.
        left: metres to its left (0 for a differential-drive robot).
        turn: heading change in radians, counter-clockwise positive.
    """

    forward: float
    left: float = 0.0
    turn: float = 0.0

    def __post_init__(self) -> None:
        for name in ("forward", "left", "turn"):
            object.__setattr__(self, name, _finite(getattr(self, name), name))


Motion = MapDisplacement | RobotMotion


def as_motion(odometry: object) -> Motion | None:
    """``odometry`` as a :class:`MapDisplacement` or :class:`RobotMotion` (None stays None).

    Accepts those classes, or a ``(dx, dy)`` pair (tuple, list or array) in the map frame.
    Raises TypeError/ValueError naming the problem for anything else.
    """
    if odometry is None or isinstance(odometry, (MapDisplacement, RobotMotion)):
        return odometry
    if isinstance(odometry, tuple) and len(odometry) == 2:  # the common case, without numpy
        return MapDisplacement(*odometry)
    if isinstance(odometry, (str, bytes, bytearray, memoryview, dict)):  # bytes are not metres
        raise TypeError(
            f"odometry must be MapDisplacement, RobotMotion or a (dx, dy) pair, got {type(odometry).__name__}"
        )
    not_masked(odometry, "odometry")
    try:
        raw = np.asarray(odometry)
    except (TypeError, ValueError):
        raw = np.asarray(None)
    if raw.dtype.kind not in "iuf":  # bool, complex, strings, objects: not a pair of real numbers
        raise TypeError(
            f"odometry must be MapDisplacement, RobotMotion or a (dx, dy) pair of real numbers, got "
            f"{type(odometry).__name__}" + (f" of dtype {raw.dtype}" if raw.dtype.kind != "O" else "")
        )
    pair = raw.astype(np.float64)
    if pair.shape != (2,):
        raise ValueError(
            f"odometry as a plain sequence must be a (dx, dy) pair in the map frame, got shape {pair.shape}; "
            f"for wheel odometry pass nightloc.RobotMotion(forward, left, turn)"
        )
    return MapDisplacement(float(pair[0]), float(pair[1]))


@dataclass(frozen=True)
class NoiseModel:
    """Standard deviations of zero-mean Gaussian odometry noise per step (the paper's Table III).

    Attributes:
        distance_std: metres, added to the length of each step.
        heading_std: radians, added to the direction of each step (map odometry) or to each
            turn (robot odometry).
        distance_per_metre: wheel odometry (robot-frame steps) only: a further length noise of
            this fraction of the step's length, in quadrature with ``distance_std``.
        heading_per_radian: wheel odometry only: a further turn noise of this fraction of the
            step's turn, in quadrature with ``heading_std``.

    The two step-scaled terms are what the filter assumes; the simulators
    (:func:`simulate_map_odometry`, :func:`simulate_robot_odometry`) draw the Table III terms only and
    refuse a model with step-scaled terms.
    """

    distance_std: float
    heading_std: float
    distance_per_metre: float = 0.0
    heading_per_radian: float = 0.0

    @property
    def step_scaled(self) -> bool:
        """Whether the model has a step-scaled term (``distance_per_metre`` or ``heading_per_radian``)."""
        return self.distance_per_metre > 0 or self.heading_per_radian > 0


#: The paper's Table III.
NOISE_MODELS: dict[int, NoiseModel] = {
    0: NoiseModel(0.0, 0.0),
    1: NoiseModel(0.1, 0.02),
    2: NoiseModel(0.25, 0.05),
    3: NoiseModel(0.5, 0.1),
}

#: The noise the filter assumes for a robot's own wheel odometry (``nightloc localize`` and
#: ``evaluate --odometry log`` when the log's steps are robot-frame): 4 % of each step's length
#: and Table III model 1's 0.02 rad per step (docs/localization.md, lawn scale). Defined in the core
#: (``kWheelOdometryNoise``, nightloc/localizer.hpp), which ``nightloc_replay`` assumes too.
WHEEL_ODOMETRY_NOISE = NoiseModel(*_core.WHEEL_ODOMETRY_NOISE)


def noise_model(model: int | NoiseModel) -> NoiseModel:
    """A :class:`NoiseModel` from a Table III number (0-3) or a NoiseModel (checked)."""
    if isinstance(model, NoiseModel):
        chosen = model
    elif isinstance(model, (int, np.integer)) and not isinstance(model, bool):
        if int(model) not in NOISE_MODELS:
            raise ValueError(f"noise model must be one of {sorted(NOISE_MODELS)} (the paper's Table III), got {model}")
        chosen = NOISE_MODELS[int(model)]
    else:
        raise TypeError(f"noise model must be an int 0-3 or a NoiseModel, got {type(model).__name__}")
    for name in ("distance_std", "heading_std", "distance_per_metre", "heading_per_radian"):
        value = getattr(chosen, name)
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value}")
    return chosen


def log_noise_model(odometry: Sequence[object]) -> int | NoiseModel:
    """The noise the filter assumes for a log's own odometry when none is given:
    :data:`WHEEL_ODOMETRY_NOISE` when any step is a :class:`RobotMotion` (wheel odometry), else
    Table III model 1 (map-frame steps, or no odometry)."""
    return WHEEL_ODOMETRY_NOISE if any(isinstance(m, RobotMotion) for m in odometry) else 1


def _simulated_noise(model: int | NoiseModel) -> NoiseModel:
    """The checked model of a simulator: ValueError for step-scaled terms, which it cannot draw."""
    noise = noise_model(model)
    if noise.step_scaled:
        raise ValueError(
            f"the odometry simulators draw Table III noise (distance_std, heading_std) only, got {noise}: "
            f"set distance_per_metre and heading_per_radian to 0 (they are what the filter assumes)"
        )
    return noise


def _poses(positions: object, headings: object | None = None):
    not_masked(positions, "positions")
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 2 or pos.shape[0] == 0:
        raise ValueError(f"positions must be (n_frames, 2) metres, got shape {pos.shape}")
    coordinates(pos, "positions")
    if headings is None:
        return pos, None
    head = np.asarray(headings, dtype=np.float64)
    if head.shape != (pos.shape[0],):
        raise ValueError(f"headings must be ({pos.shape[0]},) radians, got shape {head.shape}")
    if not np.isfinite(head).all():
        raise ValueError("headings contain NaN or infinity")
    return pos, head


def true_map_steps(positions: np.ndarray) -> np.ndarray:
    """``(N, 2)`` map-frame steps: row k is ``positions[k] - positions[k-1]``; row 0 is zero."""
    pos, _ = _poses(positions)
    return np.vstack([np.zeros((1, 2)), np.diff(pos, axis=0)])


def true_robot_motions(positions: np.ndarray, headings: np.ndarray) -> list[RobotMotion]:
    """The exact robot-frame motion between consecutive poses; element 0 is zero motion."""
    pos, head = _poses(positions, headings)
    if head is None:
        raise ValueError("robot-frame motion needs headings")
    motions = [RobotMotion(0.0, 0.0, 0.0)]
    for k in range(1, len(pos)):
        dx, dy = pos[k] - pos[k - 1]
        c, s = math.cos(head[k - 1]), math.sin(head[k - 1])
        motions.append(RobotMotion(c * dx + s * dy, -s * dx + c * dy, float(wrap_angle(head[k] - head[k - 1]))))
    return motions


def simulate_map_odometry(
    positions: np.ndarray, model: int | NoiseModel, rng: np.random.Generator | int | None = None
) -> np.ndarray:
    """Noisy map-frame steps from ground-truth positions (the paper's simulated odometry).

    Each step ``v = p[k] - p[k-1]`` is measured as length ``|v| + N(0, distance_std)`` along
    direction ``atan2(v) + N(0, heading_std)``, independently per step.

    Args:
        positions: ``(N, 2)`` true positions of consecutive frames (metres).
        model: Table III number (0-3) or a :class:`NoiseModel`.
        rng: a ``numpy.random.Generator`` or a seed.

    Returns:
        ``(N, 2)`` steps in metres; row 0 (no previous frame) is zero. Model 0 returns the
        exact steps.
    """
    noise = _simulated_noise(model)
    steps = true_map_steps(positions)
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    n = len(steps) - 1
    if n == 0:
        return steps
    length = np.hypot(steps[1:, 0], steps[1:, 1]) + generator.normal(0.0, 1.0, n) * noise.distance_std
    direction = np.arctan2(steps[1:, 1], steps[1:, 0]) + generator.normal(0.0, 1.0, n) * noise.heading_std
    if noise.distance_std == 0 and noise.heading_std == 0:
        return steps
    steps[1:, 0] = length * np.cos(direction)
    steps[1:, 1] = length * np.sin(direction)
    return steps


def simulate_robot_odometry(
    positions: np.ndarray,
    headings: np.ndarray,
    model: int | NoiseModel,
    rng: np.random.Generator | int | None = None,
) -> list[RobotMotion]:
    """Noisy wheel-odometry readings between consecutive ground-truth poses.

    The true robot-frame motion (:func:`true_robot_motions`) with ``N(0, distance_std)`` added
    to the length of its translation (direction in the robot frame kept) and ``N(0,
    heading_std)`` added to its turn, independently per step. Heading errors then accumulate
    when the motions are chained (:func:`robot_steps_to_map`), as with real encoders.

    Returns:
        N :class:`RobotMotion`; element 0 is zero motion.
    """
    noise = _simulated_noise(model)
    motions = true_robot_motions(positions, headings)
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    out = [motions[0]]
    n = len(motions) - 1
    d_noise = generator.normal(0.0, 1.0, n) * noise.distance_std
    t_noise = generator.normal(0.0, 1.0, n) * noise.heading_std
    for k, motion in enumerate(motions[1:]):
        length = math.hypot(motion.forward, motion.left)
        if length > 0:
            scale = (length + d_noise[k]) / length
            forward, left = motion.forward * scale, motion.left * scale
        else:
            forward, left = float(d_noise[k]), 0.0
        out.append(RobotMotion(forward, left, motion.turn + float(t_noise[k])))
    return out


def robot_steps_to_map(motions: Sequence[Motion], heading_now: float | None) -> np.ndarray:
    """Map-frame steps of consecutive motions, given the heading after the last one.

    ``motions[k]`` takes the robot from frame k to frame k+1. A :class:`MapDisplacement` is
    already in the map frame. A :class:`RobotMotion` is in the frame-k robot frame: the heading
    at frame k is recovered backwards from ``heading_now`` (the heading at the last frame) by
    undoing the turns of the robot motions after it, and rotates it into the map frame.

    Args:
        motions: the motions, oldest first.
        heading_now: radians; needed (finite) only when a RobotMotion is present.

    Returns:
        ``(len(motions), 2)`` metres in the map frame.
    """
    n = len(motions)
    map_steps = [(m.dx, m.dy) for m in motions if type(m) is MapDisplacement]
    if len(map_steps) == n:
        return np.array(map_steps, dtype=np.float64).reshape(n, 2)
    out = np.zeros((n, 2))
    needs_heading = any(isinstance(m, RobotMotion) for m in motions)
    if needs_heading:
        if heading_now is None or not math.isfinite(float(heading_now)):
            raise ValueError(
                "robot-frame odometry (RobotMotion) needs a heading estimate, and there is none: the reference "
                "map has no headings; pass map-frame displacements (MapDisplacement or (dx, dy)) instead"
            )
        heading = float(heading_now)
    for k in range(n - 1, -1, -1):
        motion = motions[k]
        if isinstance(motion, MapDisplacement):
            out[k] = (motion.dx, motion.dy)
            continue
        if not isinstance(motion, RobotMotion):
            raise TypeError(f"motions[{k}] must be MapDisplacement or RobotMotion, got {type(motion).__name__}")
        heading -= motion.turn  # heading at the start of this motion
        c, s = math.cos(heading), math.sin(heading)
        out[k] = (c * motion.forward - s * motion.left, s * motion.forward + c * motion.left)
    return out


def compose_motions(motions: Sequence[Motion]) -> Motion:
    """One motion equal to ``motions`` one after the other (all of one kind).

    Robot-frame motions compose as poses (the result is in the frame of the first); map-frame
    displacements add up.
    """
    if not motions:
        raise ValueError("nothing to compose")
    displacements = [m for m in motions if isinstance(m, MapDisplacement)]
    if len(displacements) == len(motions):
        return MapDisplacement(sum(m.dx for m in displacements), sum(m.dy for m in displacements))
    robot = [m for m in motions if isinstance(m, RobotMotion)]
    if len(robot) != len(motions):
        raise ValueError("cannot compose robot-frame and map-frame motions")
    x = y = heading = 0.0
    for m in robot:
        c, s = math.cos(heading), math.sin(heading)
        x += c * m.forward - s * m.left
        y += s * m.forward + c * m.left
        heading += m.turn
    return RobotMotion(x, y, heading)


def reverse_motion(motion: Motion | None) -> Motion | None:
    """The motion back: from where ``motion`` ends to where it started, in the frame it ends in
    (robot-frame: at the later pose; ``compose_motions([motion, reverse_motion(motion)])`` is no
    motion); None (unknown) stays None. What a filter run backwards in time is fed."""
    if motion is None:
        return None
    if isinstance(motion, MapDisplacement):
        return MapDisplacement(-motion.dx, -motion.dy)
    c, s = math.cos(motion.turn), math.sin(motion.turn)
    return RobotMotion(-(c * motion.forward + s * motion.left), s * motion.forward - c * motion.left, -motion.turn)


PathLike = Union[str, "os.PathLike[str]"]


def read_odometry(file: PathLike, keys: Sequence[object], key_column: str = "image") -> list[Motion | None]:
    """The motion before each of ``keys`` (a traverse's frames, in order) from an odometry CSV
    (``image,forward,left,turn`` or ``image,dx,dy``, see :mod:`nightloc.io.odometry_csv`).

    Args:
        file: the CSV, e.g. ``<traverse>/odometry.csv``.
        keys: the traverse's image names (or frame indices for ``key_column="frame"``, a video).
        key_column: ``"image"`` or ``"frame"``.

    Returns:
        One motion per key: element 0 is None (nothing before the first frame); element k the
        log's rows after frame k-1 up to frame k, composed (frames the traverse skips, e.g. with
        ``frame_step``, are not lost).

    Raises:
        DatasetError: a frame without a row, rows out of the traverse's order, malformed rows.
    """
    from ..errors import DatasetError
    from ..io.odometry_csv import read_odometry_rows

    rows, form = read_odometry_rows(file, key_column)
    make = RobotMotion if form == "robot" else MapDisplacement
    position = {key: k for k, (key, _, _) in enumerate(rows)}
    out: list[Motion | None] = []
    previous = -1
    for j, key in enumerate(keys):
        k = position.get(key)
        if k is None:
            raise DatasetError(f"{file} has no row for {key_column} {key!r} (frame {j} of the traverse)")
        if k <= previous:
            raise DatasetError(
                f"{file} line {rows[k][2]}: {key_column} {key!r} comes before the traverse's previous frame; "
                f"rows must be in the order the frames were recorded"
            )
        out.append(None if j == 0 else compose_motions([make(*values) for _, values, _ in rows[previous + 1 : k + 1]]))
        previous = k
    return out


def traverse_odometry(traverse: Traverse, file: PathLike | None = None) -> list[Motion | None]:
    """The odometry of a :class:`~nightloc.Traverse`: :func:`read_odometry` of ``file`` (default
    ``<traverse folder>/odometry.csv``; a video's log names its CSV, keyed by ``frame``), or a
    bag's own (:attr:`Traverse.motions`, from its odometry topic) as :class:`RobotMotion`."""
    from pathlib import Path

    from ..errors import DatasetError

    video = traverse.is_video
    if file is None and traverse.is_bag:
        if traverse.motions is None:
            raise DatasetError(
                f"bag {traverse.root} has no odometry (a nav_msgs/Odometry topic or an odom -> base_link transform on "
                f"/tf); name its topic with --odometry-topic, or localize without odometry: --odometry none"
            )
        motions: list[Motion | None] = [None]
        motions += [RobotMotion(*(float(v) for v in row)) for row in traverse.motions[1:]]
        return motions
    if file is None:
        if video:
            raise DatasetError(
                f"{traverse.root} is a video: name its odometry CSV (frame,forward,left,turn or frame,dx,dy)"
            )
        file = Path(traverse.root) / "odometry.csv"
    frames = traverse.frame_indices if video else None  # a video's frames are keyed by index
    keys: list[object] = list(traverse.names) if frames is None else list(frames)
    return read_odometry(file, keys, "frame" if video else "image")
