"""A small synthetic video for traverse tests."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def write_video(path: Path, n: int, h: int = 48, w: int = 64) -> list:
    """Writes an MJPG .avi whose frame i is a flat image of grey level 10 + 12*i (robust to JPEG)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (w, h))
    assert writer.isOpened()
    levels = []
    for i in range(n):
        level = 10 + 12 * i
        image = np.full((h, w, 3), level, np.uint8)
        image[: h // 4, : w // 4] = 255 - level  # some structure
        writer.write(image)
        levels.append(level)
    writer.release()
    return levels
