"""What a dataset's description records about one of its traverses: the camera that took it.

``nightloc synth`` writes ``dataset.json`` beside the traverses it renders (``OUT/<traverse>/``).
It names the camera: ``"view"`` at its top level (the garden, living room and large garden
worlds) or ``"camera": {"view": ...}`` (the creek), ``"panoramic"`` or ``"forward"``. A command
that prepares a traverse takes the camera from there instead of assuming one.

Only a description written by nightloc and listing the traverse by its folder name counts;
anything else (no file, another tool's JSON, a damaged file) records nothing.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from .files import open_regular

__all__ = ["DATASET_DESCRIPTION", "RecordedCamera", "recorded_camera"]

#: The description's file name, in the folder holding the traverses.
DATASET_DESCRIPTION = "dataset.json"
#: The most a description is read of (bytes); a longer file is not nightloc's.
_MAX_BYTES = 1 << 20


@dataclass(frozen=True)
class RecordedCamera:
    """The camera a dataset description records for a traverse.

    Attributes:
        camera: the camera's name as recorded (nightloc writes ``"panoramic"`` or ``"forward"``).
        source: the ``dataset.json`` that says so.
    """

    camera: str
    source: Path


def recorded_camera(traverse_root: Path | str) -> RecordedCamera | None:
    """The camera that ``traverse_root/../dataset.json`` records for the traverse folder
    ``traverse_root``, or None where no nightloc description lists it."""
    root = Path(traverse_root)
    source = root.parent / DATASET_DESCRIPTION
    if not root.is_dir() or not source.is_file():
        return None
    try:
        with open_regular(source, "dataset description", ValueError) as stream:
            content = json.loads(stream.read(_MAX_BYTES).decode("utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(content, dict) or not str(content.get("generator", "")).startswith("nightloc."):
        return None
    traverses = content.get("traverses")
    if not isinstance(traverses, dict) or root.name not in traverses:
        return None
    camera = content.get("camera")
    view = content.get("view", camera.get("view") if isinstance(camera, dict) else None)
    if not isinstance(view, str):
        return None
    return RecordedCamera(view, source)
