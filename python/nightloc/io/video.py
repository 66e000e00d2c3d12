"""Video files as traverses: which suffixes are videos, counting frames, decoding chosen frames.

Decoding goes through ``cv2.VideoCapture``; frames come out as OpenCV decodes them (BGR
``(H, W, 3)`` or grey ``(H, W)`` uint8). Problems raise :class:`~nightloc.errors.DatasetError`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import cv2
import numpy as np

from ..errors import DatasetError
from .files import check_regular

__all__ = ["VIDEO_SUFFIXES", "open_video", "read_video_frames", "video_frame_count", "video_frame_rate"]

#: File suffixes (lower case) that :func:`~nightloc.load_traverse` opens as videos.
VIDEO_SUFFIXES = frozenset({".mp4", ".avi", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".webm", ".wmv", ".ogv"})


def open_video(file: Path) -> cv2.VideoCapture:
    """An opened capture of ``file``; DatasetError when it is not a regular file (a FIFO would
    block the decoder) or OpenCV cannot open it."""
    check_regular(file, "video", DatasetError)
    capture = cv2.VideoCapture(str(file))
    if not capture.isOpened():
        capture.release()
        raise DatasetError(f"video {file} cannot be opened (corrupt, or a codec OpenCV lacks)")
    return capture


def video_frame_count(file: Path) -> int:
    """Number of frames of ``file`` (from the container, or by decoding when it does not say)."""
    capture = open_video(file)
    try:
        count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        if count <= 0:  # the container does not say: count by decoding
            count = 0
            while capture.grab():
                count += 1
    finally:
        capture.release()
    if count <= 0:
        raise DatasetError(f"video {file} holds no frames")
    return count


def video_frame_rate(file: Path) -> float | None:
    """Frames per second the container states, or None when it states none (frame ``i`` of the
    video is then at ``i / rate`` seconds from its start)."""
    capture = open_video(file)
    try:
        rate = float(capture.get(cv2.CAP_PROP_FPS))
    finally:
        capture.release()
    return rate if math.isfinite(rate) and 0 < rate < 10_000 else None


def read_video_frames(
    file: Path,
    frame_indices: Sequence[int],
    positions: Iterable[int],
    ended: Callable[[int, int], Exception],
) -> Iterator[tuple[int, np.ndarray]]:
    """Decodes the frames at the given ascending ``positions`` of ``frame_indices``.

    Yields ``(position, frame)``. Seeks to the first frame where the backend can, then decodes
    forward. ``ended(position, decoded)`` makes the error raised when the video ends (or is
    corrupt) before frame ``frame_indices[position]``, ``decoded`` frames into it.
    """
    capture = open_video(file)
    try:
        current = 0  # index of the next frame the capture returns
        first = True
        for position in positions:
            target = frame_indices[position]
            if first and target > 0:
                capture.set(cv2.CAP_PROP_POS_FRAMES, float(target))
                current = int(round(capture.get(cv2.CAP_PROP_POS_FRAMES)))
                if current != target:  # the backend cannot seek: decode from the start
                    capture.release()
                    capture = open_video(file)
                    current = 0
            first = False
            if target < current:
                raise ValueError("video frames must be read in ascending order")
            while current < target:
                if not capture.grab():
                    raise ended(position, current)
                current += 1
            ok, frame = capture.read()
            if not ok or frame is None:
                raise ended(position, current)
            current += 1
            if frame.ndim == 3 and frame.shape[2] == 1:
                frame = frame[:, :, 0]
            yield position, np.ascontiguousarray(frame)
    finally:
        capture.release()
