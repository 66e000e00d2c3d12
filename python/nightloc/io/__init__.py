"""Data on disk: image files, pose files, videos, traverses, reference map files and atomic writes.

* :mod:`~nightloc.io.images` — image suffixes, natural-order folder listing, decoding/encoding;
* :mod:`~nightloc.io.poses` — ``poses.csv`` (``image,x,y[,heading]``) and frame-keyed pose CSVs;
* :mod:`~nightloc.io.video` — video files as traverses;
* :mod:`~nightloc.io.bag` — ROS 1 and ROS 2 bags as traverses (frames, times, odometry, poses);
* :mod:`~nightloc.io.kinds` — what a path is (a map, a bag, a traverse folder, ...) for messages;
* :mod:`~nightloc.io.trajectory` — ``trajectory.csv`` and the TUM trajectory format;
* :mod:`~nightloc.io.traverse` — :class:`Traverse`, :func:`load_traverse`, :func:`save_traverse`;
* :mod:`~nightloc.io.firmware_log` — a log in the layout the firmware replay reads (PGM/PPM frames);
* :mod:`~nightloc.io.map_file` — the reference map file (``.npz``: arrays, JSON header, checksums);
* :mod:`~nightloc.io.atomic` — atomic file and folder writes.
"""

from __future__ import annotations

# io depends on no other stage, so that every stage may use it. The reference map itself
# (nightloc.ReferenceMap) is built on preparation and matching: it lives in nightloc.mapping.
from .traverse import IMAGE_SUFFIXES, VIDEO_SUFFIXES, Traverse, load_traverse, save_traverse

__all__ = ["IMAGE_SUFFIXES", "VIDEO_SUFFIXES", "Traverse", "load_traverse", "save_traverse"]
