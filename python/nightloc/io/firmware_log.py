"""A log in the firmware's layout: what ``nightloc_replay`` (cpp/apps/) reads without Python.

The firmware reads ``images/`` of binary 8-bit PGM (grey) or PPM (colour) frames whose names sort,
in natural order, as the frames were recorded, and ``odometry.csv`` with one row per frame under
those names (cpp/apps/replay_log.hpp). :func:`write_firmware_log` writes any log nightloc reads
(a folder of PNG or JPEG frames, a video, a ROS bag) in that layout, as one set: the frames
re-encoded losslessly (the pixels nightloc decodes, so the firmware prepares the same bytes), the
odometry rows renamed to match, and the log's times and poses kept (``poses.csv``).
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Union

import numpy as np

from ..errors import DatasetError
from .atomic import parent_folders
from .images import natural_key
from .traverse import Traverse, save_traverse

__all__ = ["FIRMWARE_FRAME_SUFFIXES", "firmware_frame_names", "write_firmware_log"]

PathLike = Union[str, "os.PathLike[str]"]

#: The firmware's frame files by channels: 1 grey -> binary PGM (P5), 3 colour -> binary PPM (P6).
FIRMWARE_FRAME_SUFFIXES = {1: ".pgm", 3: ".ppm"}


def _plain(name: str) -> bool:
    """A name ``save_traverse`` writes and a CSV row holds as it is."""
    return bool(name) and not name.startswith(".") and not any(c in name for c in '/\\,"\r\n')


def firmware_frame_names(names: Sequence[str], suffix: str) -> list[str]:
    """The frames' file names in the firmware's log: each name with ``suffix`` instead of its own
    (``000123.png`` -> ``000123.pgm``, a video's ``frame_000123`` -> ``frame_000123.pgm``), or
    ``000000<suffix>``, ``000001<suffix>``, ... in frame order where the kept names would not be
    unique plain file names in natural order (the order the firmware reads them in)."""
    kept = [Path(name).stem + suffix for name in names]
    if all(_plain(n) for n in kept) and len(set(kept)) == len(kept) and sorted(kept, key=natural_key) == kept:
        return kept
    width = max(6, len(str(len(names) - 1)))
    return [f"{k:0{width}d}{suffix}" for k in range(len(names))]


def _checked_frames(log: Traverse, first: np.ndarray, rest: Iterator[tuple[int, np.ndarray]]) -> Iterator[np.ndarray]:
    """The frames, each checked to be 8-bit and of the first frame's kind (grey or colour)."""
    for index, frame in itertools.chain([(0, first)], rest):
        if frame.dtype != np.uint8:
            raise DatasetError(
                f"frame {log.names[index]!r} of {log.root} is {frame.dtype.itemsize * 8}-bit: the firmware prepares "
                f"8-bit frames only (nightloc localize reads 16-bit logs)"
            )
        if frame.ndim != first.ndim:
            raise DatasetError(
                f"frame {log.names[index]!r} of {log.root} is {'colour' if frame.ndim == 3 else 'grey'} but the first "
                f"frame is not: a firmware log holds one kind of frame"
            )
        yield frame


def write_firmware_log(
    log: Traverse, path: PathLike, odometry: Sequence[object], *, overwrite: bool = False
) -> Traverse:
    """Writes ``log`` with its ``odometry`` (one motion per frame, as
    :func:`nightloc.traverse_odometry` gives it) to the folder ``path`` in the firmware's layout,
    atomically (all or nothing; missing parent folders are created, and removed again on failure).

    ``images/``: the frames as PGM or PPM (:data:`FIRMWARE_FRAME_SUFFIXES`) named by
    :func:`firmware_frame_names`; ``odometry.csv``: ``image,forward,left,turn`` or ``image,dx,dy``
    under those names, with the log's ``timestamp`` column when it has times; ``poses.csv`` when
    the log has poses. ``log`` is only read. An existing ``path`` is replaced only with
    ``overwrite`` and only when it holds a log (``images/``, ``poses.csv``, ``odometry.csv``).

    Raises DatasetError for a 16-bit frame, or grey and colour frames mixed (the firmware reads
    8-bit frames of one kind), and ValueError when ``odometry`` does not have one motion per frame.

    Returns:
        The written log as a :class:`Traverse`.
    """
    if len(odometry) != len(log):
        raise ValueError(f"{len(odometry)} odometry motions for the {len(log)} frames of {log.root}")
    frames = log.frames(progress_desc=f"exporting {log.root.name}")
    _, first = next(frames)
    names = firmware_frame_names(log.names, FIRMWARE_FRAME_SUFFIXES[1 if first.ndim == 2 else 3])
    with parent_folders(path):
        return save_traverse(
            path,
            _checked_frames(log, first, frames),
            log.positions,
            log.headings,
            names,
            odometry=list(odometry),
            timestamps=log.timestamps,
            overwrite=overwrite,
        )
