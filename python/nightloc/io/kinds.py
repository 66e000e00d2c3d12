"""What a path holds, in words: a reference map, a traverse folder, a ROS bag, a video, ...

Commands take several paths in a fixed order (``nightloc localize MAP LOG``); given them swapped,
or a file of another kind, the error names what the path *is* (":file:`garden.map` is a
nightloc reference map, not a traverse") instead of what failed deep inside a reader (OpenCV's
"cannot open the video"). :func:`path_kind` looks at a few bytes and names only; it never reads
a file whole and never follows a FIFO or device (those are named by :mod:`nightloc.io.files`).
"""

from __future__ import annotations

import os
import stat
import zipfile
from pathlib import Path
from typing import Union

from .images import IMAGE_SUFFIXES, list_images

__all__ = [
    "BAG_STORAGE_SUFFIXES",
    "MAP",
    "ROS1_BAG",
    "ROS2_BAG",
    "ROS2_STORAGE",
    "bag_kind",
    "path_kind",
]

PathLike = Union[str, "os.PathLike[str]"]

#: Kinds that :func:`path_kind` names (the words are used in error messages).
MAP = "a nightloc reference map (nightloc build-map)"
ROS1_BAG = "a ROS 1 bag"
ROS2_BAG = "a ROS 2 bag"
ROS2_STORAGE = "a ROS 2 bag's storage file"

#: Suffixes of the files a ROS 2 bag keeps its messages in (a lone one reads as a bag, too).
BAG_STORAGE_SUFFIXES = frozenset({".mcap", ".db3"})

_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_MCAP_MAGIC = b"\x89MCAP0\r\n"
_SQLITE_MAGIC = b"SQLite format 3\x00"
_MAP_MEMBER = "header.npy"

_WORDS_BY_SUFFIX = {
    ".csv": "a CSV file",
    ".toml": "a TOML parameter file",
    ".json": "a JSON file",
    ".txt": "a text file",
    ".md": "a text file",
    ".yaml": "a YAML file",
    ".yml": "a YAML file",
    ".npy": "a numpy array file",
    ".pdf": "a PDF file",
    ".svg": "an SVG figure",
}


def _head(path: Path, size: int = 16) -> bytes:
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return b""
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return b""
        return os.read(fd, size)
    except OSError:
        return b""
    finally:
        os.close(fd)


def _is_map(path: Path) -> bool:
    try:
        with zipfile.ZipFile(path) as archive:
            return _MAP_MEMBER in archive.namelist()
    except (OSError, zipfile.BadZipFile, ValueError, EOFError, NotImplementedError):
        return False


def _has_images(folder: Path) -> bool:
    try:
        return bool(list_images(folder))
    except (OSError, ValueError):  # an odd entry with an image suffix: still a folder of images
        return True


def bag_kind(path: PathLike) -> str | None:
    """:data:`ROS1_BAG`, :data:`ROS2_BAG` (a folder with ``metadata.yaml``), :data:`ROS2_STORAGE`
    (a lone ``.mcap`` or ``.db3`` file), or None when ``path`` is no bag."""
    target = Path(path)
    if target.is_dir():
        if (target / "metadata.yaml").is_file() and any(
            p.suffix.lower() in BAG_STORAGE_SUFFIXES for p in target.iterdir() if p.is_file()
        ):
            return ROS2_BAG
        return None
    head = _head(target)
    if head.startswith(_ROS1_MAGIC) or (target.suffix.lower() == ".bag" and not head and target.is_file()):
        return ROS1_BAG
    if head.startswith(_MCAP_MAGIC) or (head.startswith(_SQLITE_MAGIC) and target.suffix.lower() == ".db3"):
        return ROS2_STORAGE
    return None


def path_kind(path: PathLike) -> str:
    """What ``path`` is, as words for an error message: "a nightloc reference map (nightloc
    build-map)", "a ROS 2 bag", "a traverse folder", "a folder without images", "an image file",
    "a CSV file", "a video file", "a file of another kind", "missing", ... (from its type, its
    first bytes and its suffix)."""
    target = Path(path)
    if not os.path.lexists(target):
        return "missing"
    bag = bag_kind(target)
    if bag is not None:
        return bag
    if target.is_dir():
        if (target / "images").is_dir() or _has_images(target):
            return "a traverse folder"
        if (target / "dataset.json").is_file():
            return "a synthetic dataset folder (its traverses are sub-folders)"
        return "a folder without images"
    try:
        mode = os.stat(target).st_mode
    except OSError:
        return "not a readable file"
    if not stat.S_ISREG(mode):
        return "not a regular file"
    suffix = target.suffix.lower()
    head = _head(target)
    if head.startswith(b"PK\x03\x04"):
        return MAP if _is_map(target) else "a zip archive"
    if head.startswith(b"\x93NUMPY"):
        return "a numpy array file"
    if head.startswith(_SQLITE_MAGIC):
        return "an SQLite database"
    if not head:
        return "an empty file"
    if suffix in IMAGE_SUFFIXES:
        return "an image file"
    if suffix in _WORDS_BY_SUFFIX:
        return _WORDS_BY_SUFFIX[suffix]
    from .video import VIDEO_SUFFIXES

    if suffix in VIDEO_SUFFIXES:
        return "a video file"
    if all(32 <= b < 127 or b in (9, 10, 13) for b in head):
        return "a text file"
    return "a file of another kind"
