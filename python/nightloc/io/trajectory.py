"""Trajectory files: a localized log as ``trajectory.csv`` and in the TUM format.

* ``trajectory.csv``: header :data:`TRAJECTORY_HEADER`, one row per frame: the frame's name,
  position (m), heading (rad; ``nan`` when the map has none), the filter's confidence and credible
  radius (m), the best reference, and the frame's time in seconds (``nan`` when the log does not
  carry times).
* TUM (``trajectory.tum``, as the TUM RGB-D benchmark and ``evo`` read it): one line per frame,
  ``timestamp tx ty tz qx qy qz qw``, separated by single spaces, no header: seconds, metres
  (``tz`` 0: the robot moves in the plane) and the unit quaternion of the heading, a rotation
  about z (``qx = qy = 0``, ``qz = sin(heading / 2)``, ``qw = cos(heading / 2)``).
* ``trajectory_confidence.csv`` beside a TUM file (the format has no column for it): header
  :data:`TUM_CONFIDENCE_HEADER`, one row per line of the TUM file, in its order and with its
  timestamp written the same way: the filter's confidence and credible radius (m) of that pose.

All are written atomically (:func:`nightloc.io.atomic.atomic_file`).
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Union

import numpy as np

from .atomic import atomic_file

__all__ = [
    "TRAJECTORY_FORMATS",
    "TRAJECTORY_HEADER",
    "TUM_CONFIDENCE_FILE",
    "TUM_CONFIDENCE_HEADER",
    "confident_frames",
    "write_trajectory_csv",
    "write_tum",
    "write_tum_confidence",
]

PathLike = Union[str, "os.PathLike[str]"]

#: Columns of ``trajectory.csv``.
TRAJECTORY_HEADER = ("image", "x", "y", "heading", "confidence", "credible_radius", "ref_index", "timestamp")
#: The formats ``nightloc localize --format`` writes, and their file names (mcap: a ROS 2 bag folder).
TRAJECTORY_FORMATS = {"csv": "trajectory.csv", "tum": "trajectory.tum", "mcap": "trajectory_bag"}
#: The file that pairs each line of ``trajectory.tum`` with the pose's confidence, and its columns.
TUM_CONFIDENCE_FILE = "trajectory_confidence.csv"
TUM_CONFIDENCE_HEADER = ("timestamp", "confidence", "credible_radius")


def _time(value: float | None) -> str:
    return "nan" if value is None or not math.isfinite(value) else repr(float(value))


def write_trajectory_csv(
    path: PathLike,
    names: Sequence[str],
    estimates: Sequence[Any],
    timestamps: Sequence[float] | np.ndarray | None = None,
) -> Path:
    """Writes ``trajectory.csv`` (header :data:`TRAJECTORY_HEADER`) atomically; ``estimates``
    are :class:`nightloc.Estimate` (or anything with their attributes), ``timestamps`` seconds."""
    if timestamps is not None and len(timestamps) != len(names):
        raise ValueError(f"{len(timestamps)} timestamps for {len(names)} frames")
    with atomic_file(path, "w", newline="") as stream:
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(TRAJECTORY_HEADER)
        for k, (name, e) in enumerate(zip(names, estimates)):
            writer.writerow(
                [
                    name,
                    f"{e.x:.4f}",
                    f"{e.y:.4f}",
                    f"{e.heading:.5f}",
                    f"{e.confidence:.4f}",
                    f"{e.credible_radius:.4f}",
                    e.ref_index,
                    _time(None if timestamps is None else timestamps[k]),
                ]
            )
    return Path(path)


def confident_frames(estimates: Sequence[Any], min_confidence: float = 0.0) -> list[int]:
    """Indices of the estimates whose ``confidence`` is at least ``min_confidence`` (in [0, 1];
    0 keeps every frame). ValueError for a threshold outside [0, 1]."""
    if not (isinstance(min_confidence, (int, float)) and 0.0 <= min_confidence <= 1.0):
        raise ValueError(f"the minimum confidence must be in [0, 1], got {min_confidence!r}")
    return [k for k, e in enumerate(estimates) if e.confidence >= min_confidence]


def write_tum_confidence(path: PathLike, timestamps: Sequence[float] | np.ndarray, estimates: Sequence[Any]) -> Path:
    """Writes ``trajectory_confidence.csv`` (header :data:`TUM_CONFIDENCE_HEADER`) atomically:
    one row per estimate, as :func:`write_tum` writes their lines, with the same timestamps."""
    if len(timestamps) != len(estimates):
        raise ValueError(f"{len(timestamps)} timestamps for {len(estimates)} estimates")
    with atomic_file(path, "w", newline="") as stream:
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(TUM_CONFIDENCE_HEADER)
        for t, e in zip(timestamps, estimates):
            writer.writerow([repr(float(t)), f"{e.confidence:.4f}", f"{e.credible_radius:.4f}"])
    return Path(path)


def write_tum(path: PathLike, timestamps: Sequence[float] | np.ndarray, estimates: Sequence[Any]) -> Path:
    """Writes a TUM trajectory (``timestamp tx ty tz qx qy qz qw`` per line) atomically.

    Raises ValueError when a timestamp or heading is not finite (the format has no way to say
    "unknown"), or the counts differ.
    """
    if len(timestamps) != len(estimates):
        raise ValueError(f"{len(timestamps)} timestamps for {len(estimates)} estimates")
    lines = []
    for k, (t, e) in enumerate(zip(timestamps, estimates)):
        if not math.isfinite(t):
            raise ValueError(f"frame {k} has no time ({t}); the TUM format needs one per line")
        if not math.isfinite(e.heading):
            raise ValueError(f"frame {k} has no heading; the TUM format needs an orientation per line")
        half = 0.5 * float(e.heading)
        lines.append(f"{float(t)!r} {e.x:.6f} {e.y:.6f} 0 0 0 {math.sin(half):.9f} {math.cos(half):.9f}\n")
    with atomic_file(path, "w", newline="") as stream:
        stream.writelines(lines)
    return Path(path)
