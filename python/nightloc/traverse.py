"""Traverses: the camera frames of one pass through the environment, with their poses.

A traverse on disk is either

* a **folder**: ``images/`` (any format OpenCV reads) plus an optional ``poses.csv`` with header
  ``image,x,y,heading`` (``heading`` optional, extra columns ignored). ``image`` is the file name
  inside ``images/``, ``x, y`` the position in metres in the map frame and ``heading`` radians
  (counter-clockwise from +x; wrapped to (-pi, pi]). The frames are in the row order of
  ``poses.csv``. Without ``poses.csv`` (route mode) the traverse holds every image file of the
  folder in natural file-name order (``img2.png`` before ``img10.png``) and has no poses. A
  folder with no ``images/`` sub-folder but image files of its own is read the same way (e.g.
  the Nordland ``summer/`` folder).
* a **video** file, with an optional CSV keyed by frame index (header ``frame,x,y,heading``,
  ``heading`` optional); ``frame_step=k`` keeps the frames whose index is a multiple of ``k``.

Images are read lazily: :meth:`Traverse.read` decodes one frame, :meth:`Traverse.frames` streams
them with a bounded read-ahead (and a progress bar for long loads). Bad data on disk raises
:class:`~nightloc.errors.DatasetError` naming the file and, for CSV problems, the line.
"""

from __future__ import annotations

import concurrent.futures
import csv
import math
import os
import re
import shutil
from collections import deque
from pathlib import Path
from typing import Iterable, Iterator, Optional, Sequence, Tuple, Union

import cv2
import numpy as np

from ._atomic import replace_folder, staging_folder
from . import _validate
from ._validate import thread_count
from .errors import DatasetError
from .progress import progress

__all__ = ["Traverse", "load_traverse", "save_traverse", "IMAGE_SUFFIXES", "VIDEO_SUFFIXES"]

PathLike = Union[str, "os.PathLike[str]"]

#: File suffixes (lower case) treated as images when a folder is listed.
IMAGE_SUFFIXES = frozenset(
    {".png", ".jpg", ".jpeg", ".jpe", ".bmp", ".dib", ".tif", ".tiff", ".webp", ".pgm", ".ppm", ".pbm",
     ".pnm", ".pxm", ".sr", ".ras", ".jp2"}
)
#: File suffixes (lower case) that :func:`load_traverse` opens as videos.
VIDEO_SUFFIXES = frozenset({".mp4", ".avi", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".webm", ".wmv", ".ogv"})

_POSE_FILE = "poses.csv"
_IMAGE_DIR = "images"


# --------------------------------------------------------------------------------------------
# small helpers


def natural_key(name: str) -> Tuple[object, ...]:
    """Sort key comparing runs of digits as numbers: ``img2.png`` < ``img10.png``."""
    parts = re.split(r"(\d+)", name)
    return tuple((0, int(part), part) if part.isdigit() else (1, part.lower(), part) for part in parts)


def wrap_headings(headings: np.ndarray) -> np.ndarray:
    """Angles (radians) wrapped to (-pi, pi]; values already inside are returned bit-exact."""
    values = np.asarray(headings, dtype=np.float64)
    outside = (values <= -math.pi) | (values > math.pi)
    if not outside.any():
        return values.copy()
    wrapped = np.mod(values + math.pi, 2.0 * math.pi) - math.pi
    wrapped = np.where(wrapped <= -math.pi, math.pi, wrapped)
    return np.where(outside, wrapped, values)


def _frozen(array: Optional[np.ndarray]) -> Optional[np.ndarray]:
    if array is not None:
        array.setflags(write=False)
    return array


def _decode_error_hint(path: Path) -> str:
    try:
        size = path.stat().st_size
    except OSError as error:
        return f"cannot be read ({error.strerror or error})"
    if size == 0:
        return "is empty (0 bytes)"
    return f"is not an image OpenCV can decode ({size} bytes; truncated, corrupt or another file type)"


def _jpeg_truncated(data: np.ndarray) -> bool:
    """True when a JPEG stream has no end-of-image marker after its last scan.

    Entropy-coded data never contains ``FF D9`` (0xFF bytes are stuffed), so a JPEG cut inside
    its last scan lacks the marker; older OpenCV builds decode such files with a grey fill.
    """
    raw = data.tobytes()
    if not raw.startswith(b"\xff\xd8"):
        return False
    last_scan = raw.rfind(b"\xff\xda")
    return last_scan >= 0 and raw.find(b"\xff\xd9", last_scan) < 0


def read_image_file(path: PathLike, context: str = "") -> np.ndarray:
    """Decodes one image file as stored: grey ``(H, W)`` or BGR ``(H, W, 3)``, uint8 or uint16.

    An alpha channel is dropped. Raises :class:`DatasetError` (with ``context``, e.g. the
    ``poses.csv`` line naming the file) for a missing, empty, truncated or undecodable file, or a
    float image.
    """
    file = Path(path)
    where = f" ({context})" if context else ""
    try:
        data = np.fromfile(file, dtype=np.uint8)
    except OSError as error:
        raise DatasetError(f"image {file}{where} cannot be read: {error.strerror or error}") from error
    image = cv2.imdecode(data, cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH) if data.size else None
    if image is None:
        raise DatasetError(f"image {file}{where} {_decode_error_hint(file)}")
    if file.suffix.lower() in (".jpg", ".jpeg", ".jpe") and _jpeg_truncated(data):
        raise DatasetError(f"image {file}{where} is a truncated JPEG (no end-of-image marker after its last scan)")
    if image.dtype not in (np.uint8, np.uint16):
        raise DatasetError(
            f"image {file}{where} has {image.dtype} pixels; nightloc reads 8- or 16-bit images "
            f"(convert it, e.g. to 16-bit PNG)"
        )
    if image.ndim == 3:
        channels = image.shape[2]
        if channels == 1:
            image = image[:, :, 0]
        elif channels == 4:
            image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
        elif channels != 3:
            raise DatasetError(f"image {file}{where} has {channels} channels; expected 1, 3 or 4")
    return np.ascontiguousarray(image)


# --------------------------------------------------------------------------------------------
# pose CSV files


class _PoseRow:
    __slots__ = ("line", "key", "x", "y", "heading")

    def __init__(self, line: int, key: object, x: float, y: float, heading: Optional[float]):
        self.line, self.key, self.x, self.y, self.heading = line, key, x, y, heading


def _parse_number(text: str, column: str, file: Path, line: int) -> float:
    cell = text.strip()
    if not cell:
        raise DatasetError(f"{file} line {line}: column '{column}' is empty; every row needs a number there")
    try:
        value = float(cell)
    except ValueError:
        raise DatasetError(f"{file} line {line}: column '{column}' holds {cell!r}, which is not a number") from None
    if not math.isfinite(value):
        raise DatasetError(
            f"{file} line {line}: column '{column}' is {cell!r}; positions and headings must be finite numbers"
        )
    return value


def _parse_frame(text: str, file: Path, line: int) -> int:
    cell = text.strip()
    try:
        value = int(cell)
    except ValueError:
        raise DatasetError(
            f"{file} line {line}: column 'frame' holds {cell!r}; expected a frame index (an integer >= 0)"
        ) from None
    if value < 0:
        raise DatasetError(f"{file} line {line}: frame index {value} is negative")
    return value


def read_pose_csv(file: Path, key_column: str) -> Tuple[list, bool]:
    """Rows of a poses CSV: ``(rows, has_heading)``.

    The CSV must have a header with ``key_column`` (``image`` or ``frame``), ``x`` and ``y``;
    ``heading`` is optional and other columns are ignored. Column names are matched without
    case and surrounding blanks; a UTF-8 byte-order mark and CRLF line ends are accepted; blank
    lines are skipped. Keys must be unique.
    """
    try:
        with open(file, newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle)
            header: Optional[list] = None
            header_line = 0
            rows = []
            seen = {}
            for fields in reader:
                line = reader.line_num
                if not any(field.strip() for field in fields):
                    continue
                if header is None:
                    header = [field.strip().lower() for field in fields]
                    header_line = line
                    for column in (key_column, "x", "y"):
                        if column not in header:
                            raise DatasetError(
                                f"{file} line {line}: missing column '{column}' (the header has: "
                                f"{', '.join(repr(h) for h in header)}); the header must be "
                                f"{key_column},x,y[,heading]"
                            )
                    duplicates = sorted({h for h in header if header.count(h) > 1 and h})
                    if duplicates:
                        raise DatasetError(f"{file} line {line}: column {duplicates[0]!r} appears twice in the header")
                    index = {name: header.index(name) for name in (key_column, "x", "y")}
                    has_heading = "heading" in header
                    if has_heading:
                        index["heading"] = header.index("heading")
                    continue
                if len(fields) != len(header):
                    raise DatasetError(
                        f"{file} line {line}: {len(fields)} fields, but the header (line {header_line}) has "
                        f"{len(header)}"
                    )
                raw_key = fields[index[key_column]]
                if key_column == "frame":
                    key: object = _parse_frame(raw_key, file, line)
                else:
                    key = raw_key.strip()
                    if not key:
                        raise DatasetError(f"{file} line {line}: column 'image' is empty")
                if key in seen:
                    raise DatasetError(
                        f"{file} line {line}: {key_column} {key!r} is listed twice (first on line {seen[key]})"
                    )
                seen[key] = line
                x = _parse_number(fields[index["x"]], "x", file, line)
                y = _parse_number(fields[index["y"]], "y", file, line)
                heading = _parse_number(fields[index["heading"]], "heading", file, line) if has_heading else None
                rows.append(_PoseRow(line, key, x, y, heading))
    except UnicodeDecodeError as error:
        raise DatasetError(f"{file} is not UTF-8 text ({error.reason} at byte {error.start})") from None
    except csv.Error as error:
        raise DatasetError(f"{file}: malformed CSV ({error})") from None
    except OSError as error:
        raise DatasetError(f"{file} cannot be read: {error.strerror or error}") from error
    if header is None:
        raise DatasetError(f"{file} is empty; it needs the header {key_column},x,y[,heading] and one row per frame")
    if not rows:
        raise DatasetError(f"{file} has a header but no rows; add one row per frame")
    return rows, has_heading


def _poses_from_rows(rows: list, has_heading: bool) -> Tuple[np.ndarray, Optional[np.ndarray]]:
    positions = np.array([(row.x, row.y) for row in rows], dtype=np.float64).reshape(-1, 2)
    headings = wrap_headings(np.array([row.heading for row in rows], dtype=np.float64)) if has_heading else None
    return positions, headings


# --------------------------------------------------------------------------------------------
# the traverse


class Traverse:
    """One traverse: frame names, optional poses, and lazy access to its images.

    Immutable. Build one with :func:`load_traverse` or :func:`save_traverse`.

    Attributes:
        root: the traverse folder, or the video file.
        names: file names inside the image folder (relative paths), or frame labels
            ``frame_000123`` for a video.
        positions: ``(N, 2)`` float64 metres in the map frame (read-only), or None.
        headings: ``(N,)`` float64 radians in (-pi, pi] (read-only), or None.
        frame_indices: ``(N,)`` video frame indices, or None for a folder.
        poses_file: the CSV the poses came from, or None.
    """

    __slots__ = ("_root", "_names", "_positions", "_headings", "_image_dir", "_video", "_frame_indices",
                 "_poses_file", "_lines")

    def __init__(
        self,
        *,
        root: Path,
        names: Sequence[str],
        positions: Optional[np.ndarray] = None,
        headings: Optional[np.ndarray] = None,
        image_dir: Optional[Path] = None,
        video: Optional[Path] = None,
        frame_indices: Optional[Sequence[int]] = None,
        poses_file: Optional[Path] = None,
        lines: Optional[Sequence[int]] = None,
    ):
        """Internal: use :func:`load_traverse`."""
        if (image_dir is None) == (video is None):
            raise ValueError("a Traverse reads either an image folder or a video")
        n = len(names)
        if positions is not None and positions.shape != (n, 2):
            raise ValueError(f"positions must be ({n}, 2), got {positions.shape}")
        if headings is not None and (positions is None or headings.shape != (n,)):
            raise ValueError(f"headings must be ({n},) and need positions")
        self._root = Path(root)
        self._names = tuple(names)
        self._positions = _frozen(None if positions is None else np.array(positions, dtype=np.float64))
        self._headings = _frozen(None if headings is None else np.array(headings, dtype=np.float64))
        self._image_dir = image_dir
        self._video = video
        self._frame_indices = None if frame_indices is None else tuple(int(i) for i in frame_indices)
        self._poses_file = poses_file
        self._lines = None if lines is None else tuple(lines)

    def __getstate__(self) -> dict:
        return {name: getattr(self, name) for name in self.__slots__}

    def __setstate__(self, state: dict) -> None:
        for name, value in state.items():
            object.__setattr__(self, name, value)
        _frozen(self._positions)
        _frozen(self._headings)

    # --- descriptive properties

    @property
    def root(self) -> Path:
        """The traverse folder, or the video file."""
        return self._root

    @property
    def names(self) -> Tuple[str, ...]:
        """Image file names (relative to the image folder) or video frame labels."""
        return self._names

    @property
    def positions(self) -> Optional[np.ndarray]:
        """``(N, 2)`` float64 positions in metres, or None (route traverse)."""
        return self._positions

    @property
    def headings(self) -> Optional[np.ndarray]:
        """``(N,)`` float64 headings in radians, (-pi, pi], or None."""
        return self._headings

    @property
    def has_poses(self) -> bool:
        """True when the traverse has positions."""
        return self._positions is not None

    @property
    def is_video(self) -> bool:
        """True when the frames come from a video file."""
        return self._video is not None

    @property
    def image_dir(self) -> Optional[Path]:
        """The folder the image names are relative to (None for a video)."""
        return self._image_dir

    @property
    def frame_indices(self) -> Optional[Tuple[int, ...]]:
        """Video frame index of each frame (None for an image folder)."""
        return self._frame_indices

    @property
    def poses_file(self) -> Optional[Path]:
        """The CSV file the poses were read from, or None."""
        return self._poses_file

    def __len__(self) -> int:
        return len(self._names)

    def __repr__(self) -> str:
        kind = "video" if self.is_video else "folder"
        poses = "with poses" if self.has_poses else "no poses"
        return f"Traverse({str(self._root)!r}, {kind}, {len(self)} frames, {poses})"

    def path(self, index: int) -> Path:
        """The image file of frame ``index`` (folder traverses only)."""
        if self._image_dir is None:
            raise ValueError(f"{self._root} is a video; its frames have no files of their own")
        return self._image_dir / self._names[self._check_index(index)]

    def subset(self, indices: Union[slice, Sequence[int], np.ndarray]) -> "Traverse":
        """A traverse of the frames ``indices`` (a slice or integer indices), in that order."""
        if isinstance(indices, slice):
            chosen = list(range(len(self)))[indices]
        else:
            chosen = [self._check_index(int(i)) for i in np.asarray(indices).reshape(-1)]
        if not chosen:
            raise ValueError("subset would hold no frames")
        pick = np.asarray(chosen, dtype=np.intp)
        return Traverse(
            root=self._root,
            names=[self._names[i] for i in chosen],
            positions=None if self._positions is None else self._positions[pick],
            headings=None if self._headings is None else self._headings[pick],
            image_dir=self._image_dir,
            video=self._video,
            frame_indices=None if self._frame_indices is None else [self._frame_indices[i] for i in chosen],
            poses_file=self._poses_file,
            lines=None if self._lines is None else [self._lines[i] for i in chosen],
        )

    # --- reading images

    def _check_index(self, index: int) -> int:
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise TypeError(f"frame index must be an int, got {type(index).__name__}")
        n = len(self)
        if not -n <= index < n:
            raise IndexError(f"frame {index} out of range for a traverse of {n} frames")
        return int(index) % n

    def _context(self, index: int) -> str:
        if self._lines is not None and self._poses_file is not None:
            return f"named on line {self._lines[index]} of {self._poses_file}"
        return f"frame {index} of {self._root}"

    def read(self, index: int) -> np.ndarray:
        """Decodes frame ``index`` as stored: grey ``(H, W)`` or BGR ``(H, W, 3)``.

        uint8, or uint16 for 16-bit image files; an alpha channel is dropped.
        """
        index = self._check_index(index)
        if self._image_dir is not None:
            return read_image_file(self._image_dir / self._names[index], self._context(index))
        return next(self._video_frames([index]))[1]

    def frames(
        self, batch_size: int = 64, *, progress_desc: Optional[str] = None
    ) -> Iterator[Tuple[int, np.ndarray]]:
        """Yields ``(index, image)`` for every frame in order, decoding lazily.

        Image files are decoded by a few threads ahead of the consumer; at most
        ``min(batch_size, 2 * threads)`` decoded frames wait at any time, so memory stays bounded
        whatever the length of the traverse. A video is decoded sequentially. A progress bar is
        drawn on stderr for long loads (see :mod:`nightloc.progress`).

        Args:
            batch_size: upper bound on frames decoded ahead of the consumer (>= 1).
            progress_desc: label of the progress bar (default: the traverse's name).
        """
        if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
            raise ValueError(f"batch_size must be an int >= 1, got {batch_size!r}")
        desc = progress_desc if progress_desc is not None else f"reading {self._root.name}"
        if self._video is not None:
            source: Iterator[Tuple[int, np.ndarray]] = self._video_frames(range(len(self)))
        else:
            source = self._folder_frames(int(batch_size))
        return progress(source, total=len(self), desc=desc, unit="frame")

    def _folder_frames(self, batch_size: int) -> Iterator[Tuple[int, np.ndarray]]:
        workers = min(4, thread_count(None))
        ahead = max(1, min(batch_size, 2 * workers))
        if ahead == 1 or len(self) == 1:
            for index in range(len(self)):
                yield index, self.read(index)
            return
        executor = concurrent.futures.ThreadPoolExecutor(max_workers=workers, thread_name_prefix="nightloc-read")
        pending: deque = deque()
        try:
            next_index = 0
            while next_index < len(self) or pending:
                while next_index < len(self) and len(pending) < ahead:
                    pending.append((next_index, executor.submit(self.read, next_index)))
                    next_index += 1
                index, future = pending.popleft()
                image = future.result()
                yield index, image
        finally:
            executor.shutdown(wait=True, cancel_futures=True)

    def _video_frames(self, positions: Iterable[int]) -> Iterator[Tuple[int, np.ndarray]]:
        """Decodes the frames at the given (ascending) traverse positions from the video."""
        assert self._video is not None and self._frame_indices is not None
        capture = _open_video(self._video)
        try:
            current = 0  # index of the next frame the capture returns
            first = True
            for position in positions:
                target = self._frame_indices[position]
                if first and target > 0:
                    capture.set(cv2.CAP_PROP_POS_FRAMES, float(target))
                    current = int(round(capture.get(cv2.CAP_PROP_POS_FRAMES)))
                    if current != target:  # the backend cannot seek: decode from the start
                        capture.release()
                        capture = _open_video(self._video)
                        current = 0
                first = False
                if target < current:
                    raise ValueError("video frames must be read in ascending order")
                while current < target:
                    if not capture.grab():
                        raise self._video_ended(position, current)
                    current += 1
                ok, frame = capture.read()
                if not ok or frame is None:
                    raise self._video_ended(position, current)
                current += 1
                if frame.ndim == 3 and frame.shape[2] == 1:
                    frame = frame[:, :, 0]
                yield position, np.ascontiguousarray(frame)
        finally:
            capture.release()

    def _video_ended(self, position: int, decoded: int) -> DatasetError:
        target = self._frame_indices[position]  # type: ignore[index]
        where = f" (named on line {self._lines[position]} of {self._poses_file})" if self._lines else ""
        return DatasetError(
            f"video {self._video}: frame {target}{where} cannot be decoded; the video ends or is corrupt "
            f"after {decoded} frames (truncated file, or its header claims more frames than it holds)"
        )


# --------------------------------------------------------------------------------------------
# loading


def _open_video(file: Path) -> "cv2.VideoCapture":
    capture = cv2.VideoCapture(str(file))
    if not capture.isOpened():
        capture.release()
        raise DatasetError(f"video {file} cannot be opened (missing, corrupt, or a codec OpenCV lacks)")
    return capture


def _video_frame_count(file: Path) -> int:
    capture = _open_video(file)
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


def _check_step(frame_step: int) -> int:
    if isinstance(frame_step, bool) or not isinstance(frame_step, (int, np.integer)) or frame_step < 1:
        raise ValueError(f"frame_step must be an int >= 1, got {frame_step!r}")
    return int(frame_step)


def _list_images(folder: Path) -> list:
    names = [
        entry.name
        for entry in os.scandir(folder)
        if not entry.name.startswith(".") and Path(entry.name).suffix.lower() in IMAGE_SUFFIXES and entry.is_file()
    ]
    return sorted(names, key=natural_key)


def _image_folder(root: Path) -> Path:
    images = root / _IMAGE_DIR
    if images.is_dir():
        return images
    if _list_images(root):
        return root
    raise DatasetError(
        f"{root} is not a traverse: it has no '{_IMAGE_DIR}/' folder and no image files "
        f"(expected {root}/{_IMAGE_DIR}/<frames> and optionally {root}/{_POSE_FILE})"
    )


def _inside(name: str) -> bool:
    candidate = Path(name)
    return not candidate.is_absolute() and ".." not in candidate.parts and name not in ("", ".")


def _load_folder(root: Path, frame_step: int, poses: Optional[Path]) -> Traverse:
    image_dir = _image_folder(root)
    pose_file = poses if poses is not None else root / _POSE_FILE
    if poses is None and not pose_file.exists():
        names = _list_images(image_dir)
        if not names:
            raise DatasetError(f"{image_dir} holds no image files ({', '.join(sorted(IMAGE_SUFFIXES))})")
        names = names[::frame_step]
        return Traverse(root=root, names=names, image_dir=image_dir)
    if not pose_file.is_file():
        what = "is a folder, not a CSV file" if pose_file.is_dir() else "does not exist"
        raise DatasetError(f"poses file {pose_file} {what}")
    rows, has_heading = read_pose_csv(pose_file, "image")
    missing = []
    for row in rows:
        if not _inside(row.key):
            raise DatasetError(
                f"{pose_file} line {row.line}: image {row.key!r} must be a file name inside {image_dir}"
            )
        if not (image_dir / row.key).is_file():
            missing.append(row)
    if missing:
        first = missing[0]
        more = f" ({len(missing) - 1} more files named in it are missing too)" if len(missing) > 1 else ""
        raise DatasetError(
            f"{pose_file} line {first.line}: image {first.key!r} does not exist in {image_dir}{more}"
        )
    rows = rows[::frame_step]
    positions, headings = _poses_from_rows(rows, has_heading)
    return Traverse(
        root=root,
        names=[row.key for row in rows],
        positions=positions,
        headings=headings,
        image_dir=image_dir,
        poses_file=pose_file,
        lines=[row.line for row in rows],
    )


def _load_video(file: Path, frame_step: int, poses: Optional[Path]) -> Traverse:
    count = _video_frame_count(file)
    label = f"frame_{{:0{max(6, len(str(count)))}d}}"
    if poses is None:
        frames = list(range(0, count, frame_step))
        return Traverse(root=file, names=[label.format(f) for f in frames], video=file, frame_indices=frames)
    if not poses.is_file():
        what = "is a folder, not a CSV file" if poses.is_dir() else "does not exist"
        raise DatasetError(f"poses file {poses} {what}")
    rows, has_heading = read_pose_csv(poses, "frame")
    for row in rows:
        if row.key >= count:
            raise DatasetError(f"{poses} line {row.line}: frame {row.key} is past the end of {file} ({count} frames)")
    rows = sorted((row for row in rows if row.key % frame_step == 0), key=lambda row: row.key)
    if not rows:
        raise DatasetError(f"{poses}: no frame index is a multiple of frame_step={frame_step}")
    positions, headings = _poses_from_rows(rows, has_heading)
    return Traverse(
        root=file,
        names=[label.format(row.key) for row in rows],
        positions=positions,
        headings=headings,
        video=file,
        frame_indices=[row.key for row in rows],
        poses_file=poses,
        lines=[row.line for row in rows],
    )


def load_traverse(path: PathLike, *, frame_step: int = 1, poses: Optional[PathLike] = None) -> Traverse:
    """Opens a traverse: a folder (``images/`` + optional ``poses.csv``) or a video file.

    Only names and poses are read here; images are decoded lazily by :meth:`Traverse.read` and
    :meth:`Traverse.frames`. Every file named in ``poses.csv`` must exist.

    Args:
        path: the traverse folder, or a video file (any suffix in :data:`VIDEO_SUFFIXES`, or any
            other file OpenCV can open as a video).
        frame_step: keep every ``frame_step``-th frame: rows 0, k, 2k, ... of ``poses.csv`` (or of
            the sorted image list), or for a video the frames whose index is a multiple of k.
        poses: a poses CSV to use instead of ``path/poses.csv``; for a video, the CSV keyed by
            frame index (``frame,x,y[,heading]``). Without it a video has no poses.

    Raises:
        DatasetError: missing folder or files, unreadable video, malformed CSV (naming file and
            line).
    """
    root = Path(path)
    step = _check_step(frame_step)
    pose_path = None if poses is None else Path(poses)
    if root.is_dir():
        return _load_folder(root, step, pose_path)
    if root.is_file():
        if root.suffix.lower() in IMAGE_SUFFIXES or root.suffix.lower() == ".csv":
            raise DatasetError(f"{root} is a single file; a traverse is a folder ({_IMAGE_DIR}/ + {_POSE_FILE}) or a video")
        return _load_video(root, step, pose_path)
    raise DatasetError(f"traverse {root} does not exist")


# --------------------------------------------------------------------------------------------
# saving


def _checked_image(image: object, index: int) -> np.ndarray:
    return _validate.camera_frame(
        image, f"images[{index}]",
        dtype_hint="save uint8 images (numpy.clip(x, 0, 255).astype(numpy.uint8)) or uint16",
        shape_hint="",
    )


def _checked_poses(
    positions: Optional[object], headings: Optional[object]
) -> Tuple[Optional[np.ndarray], Optional[np.ndarray]]:
    if positions is None:
        if headings is not None:
            raise ValueError("headings need positions: pass positions too, or neither")
        return None, None
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must be (N, 2) metres, got shape {pos.shape}")
    if not np.isfinite(pos).all():
        row = int(np.argwhere(~np.isfinite(pos))[0, 0])
        raise ValueError(f"positions[{row}] is {pos[row].tolist()}; positions must be finite")
    head = None
    if headings is not None:
        head = np.asarray(headings, dtype=np.float64)
        if head.shape != (len(pos),):
            raise ValueError(f"headings must be ({len(pos)},) radians to match positions, got shape {head.shape}")
        if not np.isfinite(head).all():
            raise ValueError(f"headings[{int(np.argwhere(~np.isfinite(head))[0, 0])}] is not finite")
        head = wrap_headings(head)
    return pos, head


def _checked_names(names: Optional[Sequence[str]], image_format: str) -> Optional[list]:
    if names is None:
        return None
    if isinstance(names, str):
        raise TypeError("names must be a sequence of file names, not one string")
    result = []
    seen = set()
    for i, name in enumerate(names):
        if not isinstance(name, str) or not name or "/" in name or "\\" in name or name in (".", ".."):
            raise ValueError(f"names[{i}] = {name!r} is not a plain file name")
        if name.startswith("."):
            raise ValueError(f"names[{i}] = {name!r}: hidden file names are not listed when a folder is read")
        if Path(name).suffix.lower() not in IMAGE_SUFFIXES:
            raise ValueError(f"names[{i}] = {name!r} needs an image suffix such as .{image_format}")
        if name in seen:
            raise ValueError(f"names[{i}] = {name!r} repeats an earlier name")
        if any(c in name for c in ',"\r\n'):
            raise ValueError(f"names[{i}] = {name!r} contains a comma, quote or line break")
        seen.add(name)
        result.append(name)
    return result


def _write_encoded(file: Path, image: np.ndarray, index: int) -> None:
    suffix = file.suffix.lower()
    if image.dtype == np.uint16 and suffix not in (".png", ".tif", ".tiff", ".pgm", ".ppm", ".pnm"):
        raise ValueError(f"images[{index}] is 16-bit; {suffix} stores 8-bit images only (use png or tiff)")
    options: list = []
    if suffix in (".jpg", ".jpeg", ".jpe"):
        options = [cv2.IMWRITE_JPEG_QUALITY, 95]
    ok, encoded = cv2.imencode(suffix, image, options)
    if not ok:
        raise ValueError(f"OpenCV could not encode images[{index}] as {suffix}")
    encoded.tofile(file)


def _looks_like_traverse(folder: Path) -> bool:
    entries = {entry.name for entry in os.scandir(folder)}
    return _IMAGE_DIR in entries and entries <= {_IMAGE_DIR, _POSE_FILE}


def save_traverse(
    path: PathLike,
    images: Iterable[np.ndarray],
    positions: Optional[object] = None,
    headings: Optional[object] = None,
    names: Optional[Sequence[str]] = None,
    *,
    image_format: str = "png",
    overwrite: bool = False,
) -> Traverse:
    """Writes a traverse folder (``images/`` + ``poses.csv``) atomically and opens it.

    The folder is built in a temporary sibling and renamed into place at the end, so an error or
    an interruption never leaves a half-written traverse at ``path``. Images are streamed: an
    iterator of frames is written one at a time.

    Args:
        path: the folder to create.
        images: iterable of uint8 (or uint16) images, grey ``(H, W)`` or BGR ``(H, W, 3)``.
        positions: ``(N, 2)`` metres, or None for a route traverse (no ``poses.csv``).
        headings: ``(N,)`` radians (wrapped to (-pi, pi]), or None; needs positions.
        names: the N file names (default ``000000.<format>``, ``000001.<format>``, ...).
        image_format: file suffix of the default names (``png``, ``jpg``, ``bmp``, ``tif``, ...).
        overwrite: replace an existing traverse folder at ``path`` (a folder holding anything
            else than ``images/`` and ``poses.csv`` is never replaced).

    Returns:
        The written :class:`Traverse`.
    """
    target = Path(path)
    fmt = str(image_format).lower().lstrip(".")
    if not fmt or not cv2.haveImageWriter(f"x.{fmt}"):
        raise ValueError(f"image_format {image_format!r} is not a format OpenCV can write (try 'png' or 'jpg')")
    if f".{fmt}" not in IMAGE_SUFFIXES:
        raise ValueError(f"image_format {image_format!r} is not read back by load_traverse; use one of png, jpg, bmp, tif")
    pos, head = _checked_poses(positions, headings)
    file_names = _checked_names(names, fmt)
    expected = len(pos) if pos is not None else (len(file_names) if file_names is not None else None)
    if pos is not None and file_names is not None and len(file_names) != len(pos):
        raise ValueError(f"{len(file_names)} names but {len(pos)} positions")
    if target.exists():
        if not overwrite:
            raise FileExistsError(f"{target} exists; pass overwrite=True to replace it")
        if not target.is_dir() or not _looks_like_traverse(target):
            raise FileExistsError(
                f"{target} exists and is not a traverse folder (only images/ and poses.csv); refusing to replace it"
            )
    staging = staging_folder(target)  # creates the parent folders
    try:
        image_dir = staging / _IMAGE_DIR
        image_dir.mkdir()
        written: list = []
        for index, image in enumerate(images):
            if expected is not None and index >= expected:
                raise ValueError(f"more images than the {expected} positions/names given")
            image = _checked_image(image, index)
            name = file_names[index] if file_names is not None else None
            if name is None:
                name = f"{index:06d}.{fmt}"
            _write_encoded(image_dir / name, image, index)
            written.append(name)
        if not written:
            raise ValueError("images is empty: a traverse needs at least one image")
        if expected is not None and len(written) != expected:
            raise ValueError(f"{len(written)} images but {expected} positions/names")
        if pos is not None:
            with open(staging / _POSE_FILE, "w", newline="", encoding="utf-8") as handle:
                writer = csv.writer(handle, lineterminator="\n")
                writer.writerow(["image", "x", "y"] + (["heading"] if head is not None else []))
                for i, name in enumerate(written):
                    row = [name, repr(float(pos[i, 0])), repr(float(pos[i, 1]))]
                    if head is not None:
                        row.append(repr(float(head[i])))
                    writer.writerow(row)
        replace_folder(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return load_traverse(target)

