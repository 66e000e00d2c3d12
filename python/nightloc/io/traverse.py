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
import os
from collections import deque
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Union

import cv2
import numpy as np

from .. import _validate
from .._validate import thread_count
from ..errors import DatasetError, with_cli_words
from ..progress import progress
from .atomic import atomic_folder
from .bag import DEFAULT_SYNC_TOLERANCE_S, BagFrames, load_bag
from .files import check_regular
from .images import IMAGE_SUFFIXES, list_images, read_image_file, write_image_file
from .kinds import MAP, bag_kind, path_kind
from .odometry_csv import ODOMETRY_FILE, odometry_values, read_odometry_timestamps, write_odometry_csv
from .poses import checked_poses, checked_timestamps, poses_from_rows, read_pose_csv, write_pose_csv
from .video import VIDEO_SUFFIXES, read_video_frames, video_frame_count, video_frame_rate

__all__ = ["IMAGE_SUFFIXES", "VIDEO_SUFFIXES", "Traverse", "load_traverse", "save_traverse"]

PathLike = Union[str, "os.PathLike[str]"]

_POSE_FILE = "poses.csv"
_IMAGE_DIR = "images"


def _subset_motions(motions: np.ndarray, chosen: Sequence[int]) -> np.ndarray | None:
    """The motions between the frames ``chosen`` (ascending, consecutive: the same steps; else
    the steps skipped are composed into the next kept one)."""
    out = np.zeros((len(chosen), 3))
    for k in range(1, len(chosen)):
        a, b = chosen[k - 1], chosen[k]
        if b < a:
            return None  # motions between frames out of order are unknown
        x = y = heading = 0.0
        for forward, left, turn in motions[a + 1 : b + 1]:
            c, s = np.cos(heading), np.sin(heading)
            x, y, heading = x + c * forward - s * left, y + s * forward + c * left, heading + turn
        out[k] = (x, y, np.pi - np.mod(np.pi - heading, 2 * np.pi))
    return out


def _frozen(array: np.ndarray | None) -> np.ndarray | None:
    if array is not None:
        array.setflags(write=False)
    return array


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
        timestamps: ``(N,)`` float64 seconds, the time of each frame (read-only), or None.
        motions: ``(N, 3)`` float64 ``forward, left, turn`` odometry since the previous frame
            (metres, radians; row 0 zeros) that came with the frames (a bag's), or None.
    """

    __slots__ = (
        "_bag",
        "_frame_indices",
        "_headings",
        "_image_dir",
        "_lines",
        "_motions",
        "_names",
        "_poses_file",
        "_positions",
        "_root",
        "_timestamps",
        "_video",
    )

    def __init__(
        self,
        *,
        root: Path,
        names: Sequence[str],
        positions: np.ndarray | None = None,
        headings: np.ndarray | None = None,
        image_dir: Path | None = None,
        video: Path | None = None,
        frame_indices: Sequence[int] | None = None,
        poses_file: Path | None = None,
        lines: Sequence[int] | None = None,
        bag: BagFrames | None = None,
        timestamps: np.ndarray | None = None,
        motions: np.ndarray | None = None,
    ):
        """Internal: use :func:`load_traverse`."""
        if sum(source is not None for source in (image_dir, video, bag)) != 1:
            raise ValueError("a Traverse reads one of an image folder, a video or a bag")
        n = len(names)
        if positions is not None and positions.shape != (n, 2):
            raise ValueError(f"positions must be ({n}, 2), got {positions.shape}")
        if headings is not None and (positions is None or headings.shape != (n,)):
            raise ValueError(f"headings must be ({n},) and need positions")
        if timestamps is not None and np.shape(timestamps) != (n,):
            raise ValueError(f"timestamps must be ({n},), got {np.shape(timestamps)}")
        if motions is not None and np.shape(motions) != (n, 3):
            raise ValueError(f"motions must be ({n}, 3), got {np.shape(motions)}")
        self._root = Path(root)
        self._names = tuple(names)
        self._positions = _frozen(None if positions is None else np.array(positions, dtype=np.float64))
        self._headings = _frozen(None if headings is None else np.array(headings, dtype=np.float64))
        self._image_dir = image_dir
        self._video = video
        self._frame_indices = None if frame_indices is None else tuple(int(i) for i in frame_indices)
        self._poses_file = poses_file
        self._lines = None if lines is None else tuple(lines)
        self._bag = bag
        self._timestamps = _frozen(None if timestamps is None else np.array(timestamps, dtype=np.float64))
        self._motions = _frozen(None if motions is None else np.array(motions, dtype=np.float64))

    def __getstate__(self) -> dict:
        return {name: getattr(self, name) for name in self.__slots__}

    def __setstate__(self, state: dict) -> None:
        for name, value in state.items():
            object.__setattr__(self, name, value)
        _frozen(self._positions)
        _frozen(self._headings)
        _frozen(self._timestamps)
        _frozen(self._motions)

    # --- descriptive properties

    @property
    def root(self) -> Path:
        """The traverse folder, or the video file."""
        return self._root

    @property
    def names(self) -> tuple[str, ...]:
        """Image file names (relative to the image folder) or video frame labels."""
        return self._names

    @property
    def positions(self) -> np.ndarray | None:
        """``(N, 2)`` float64 positions in metres, or None (route traverse)."""
        return self._positions

    @property
    def headings(self) -> np.ndarray | None:
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
    def is_bag(self) -> bool:
        """True when the frames come from a ROS bag's image topic."""
        return self._bag is not None

    @property
    def bag_topics(self) -> dict[str, str | None] | None:
        """A bag traverse's topics, ``{"image": ..., "odometry": ..., "pose": ...}`` (None for a
        kind it has none of), or None for a folder or video."""
        if self._bag is None:
            return None
        return {"image": self._bag.topic, "odometry": self._bag.odometry_topic, "pose": self._bag.pose_topic}

    @property
    def timestamps(self) -> np.ndarray | None:
        """``(N,)`` float64 seconds of each frame (a bag's stamps, a ``timestamp`` column, a
        video's frame times), or None when the source does not say."""
        return self._timestamps

    @property
    def motions(self) -> np.ndarray | None:
        """``(N, 3)`` float64 odometry that came with the frames (a bag's: ``forward, left,
        turn`` since the previous frame, row 0 zeros), or None; see
        :func:`nightloc.traverse_odometry`."""
        return self._motions

    @property
    def image_dir(self) -> Path | None:
        """The folder the image names are relative to (None for a video)."""
        return self._image_dir

    @property
    def frame_indices(self) -> tuple[int, ...] | None:
        """Video frame index of each frame (None for an image folder)."""
        return self._frame_indices

    @property
    def poses_file(self) -> Path | None:
        """The CSV file the poses were read from, or None."""
        return self._poses_file

    def __len__(self) -> int:
        return len(self._names)

    def __repr__(self) -> str:
        kind = "video" if self.is_video else "bag" if self.is_bag else "folder"
        poses = "with poses" if self.has_poses else "no poses"
        return f"Traverse({str(self._root)!r}, {kind}, {len(self)} frames, {poses})"

    def path(self, index: int) -> Path:
        """The image file of frame ``index`` (folder traverses only)."""
        if self._image_dir is None:
            what = "a bag" if self.is_bag else "a video"
            raise ValueError(f"{self._root} is {what}; its frames have no files of their own")
        return self._image_dir / self._names[self._check_index(index)]

    def subset(self, indices: slice | Sequence[int] | np.ndarray) -> Traverse:
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
            bag=None if self._bag is None else self._bag.subset(chosen),
            timestamps=None if self._timestamps is None else self._timestamps[pick],
            motions=None if self._motions is None else _subset_motions(self._motions, chosen),
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
        if self._bag is not None:
            return self._bag.read(index)
        return next(self._video_frames([index]))[1]

    def frames(self, batch_size: int = 64, *, progress_desc: str | None = None) -> Iterator[tuple[int, np.ndarray]]:
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
            source: Iterator[tuple[int, np.ndarray]] = self._video_frames(range(len(self)))
        elif self._bag is not None:
            source = self._bag.frames(range(len(self)))
        else:
            source = self._folder_frames(int(batch_size))
        return progress(source, total=len(self), desc=desc, unit="frame")

    def _folder_frames(self, batch_size: int) -> Iterator[tuple[int, np.ndarray]]:
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

    def _video_frames(self, positions: Iterable[int]) -> Iterator[tuple[int, np.ndarray]]:
        """Decodes the frames at the given (ascending) traverse positions from the video."""
        assert self._video is not None and self._frame_indices is not None
        return read_video_frames(self._video, self._frame_indices, positions, self._video_ended)

    def _video_ended(self, position: int, decoded: int) -> DatasetError:
        target = self._frame_indices[position]  # type: ignore[index]
        where = f" (named on line {self._lines[position]} of {self._poses_file})" if self._lines else ""
        return DatasetError(
            f"video {self._video}: frame {target}{where} cannot be decoded; the video ends or is corrupt "
            f"after {decoded} frames (truncated file, or its header claims more frames than it holds)"
        )


# --------------------------------------------------------------------------------------------
# loading


def _check_step(frame_step: int) -> int:
    if isinstance(frame_step, bool) or not isinstance(frame_step, (int, np.integer)) or frame_step < 1:
        raise ValueError(f"frame_step must be an int >= 1, got {frame_step!r}")
    return int(frame_step)


def _image_folder(root: Path) -> tuple[Path, list[str] | None]:
    """The folder holding the frames, and its listing when finding it took one (frames directly
    in ``root``)."""
    images = root / _IMAGE_DIR
    if images.is_dir():
        return images, None
    names = list_images(root)
    if names:
        return root, names
    kind = path_kind(root)
    what = f" (it is {kind})" if kind != "a folder without images" else ""
    raise DatasetError(
        f"{root} is not a traverse{what}: it has no '{_IMAGE_DIR}/' folder and no image files "
        f"(expected {root}/{_IMAGE_DIR}/<frames> and optionally {root}/{_POSE_FILE})"
    )


def _inside(name: str) -> bool:
    candidate = Path(name)
    return not candidate.is_absolute() and ".." not in candidate.parts and name not in ("", ".")


def _load_folder(root: Path, frame_step: int, poses: Path | None) -> Traverse:
    image_dir, listed = _image_folder(root)
    pose_file = poses if poses is not None else root / _POSE_FILE
    if poses is None and not os.path.lexists(pose_file):
        names = listed if listed is not None else list_images(image_dir)
        if not names:
            raise DatasetError(f"{image_dir} holds no image files ({', '.join(sorted(IMAGE_SUFFIXES))})")
        times = _odometry_times(root, names)
        names = names[::frame_step]
        return Traverse(root=root, names=names, image_dir=image_dir, timestamps=_every(times, frame_step))
    check_regular(pose_file, "poses file", DatasetError)
    rows, has_heading = read_pose_csv(pose_file, "image")
    missing = []
    for row in rows:
        name = str(row.key)
        if not _inside(name):
            raise DatasetError(f"{pose_file} line {row.line}: image {name!r} must be a file name inside {image_dir}")
        if not (image_dir / name).is_file():
            missing.append(row)
    if missing:
        first = missing[0]
        more = f" ({len(missing) - 1} more files named in it are missing too)" if len(missing) > 1 else ""
        try:
            check_regular(image_dir / str(first.key), "image", DatasetError)
        except DatasetError as error:
            if os.path.lexists(image_dir / str(first.key)):  # there, but a folder, a FIFO, a link loop, ...
                raise DatasetError(f"{pose_file} line {first.line}: {error}{more}") from None
        raise DatasetError(f"{pose_file} line {first.line}: image {first.key!r} does not exist in {image_dir}{more}")
    if rows[0].timestamp is not None:
        times = checked_timestamps(
            [r.timestamp for r in rows if r.timestamp is not None], [r.line for r in rows], pose_file
        )
    else:
        times = _odometry_times(root, [str(row.key) for row in rows])
    rows = rows[::frame_step]
    positions, headings = poses_from_rows(rows, has_heading)
    return Traverse(
        root=root,
        names=[str(row.key) for row in rows],
        positions=positions,
        headings=headings,
        image_dir=image_dir,
        poses_file=pose_file,
        lines=[row.line for row in rows],
        timestamps=_every(times, frame_step),
    )


def _checked_times(timestamps: object | None, written_somewhere: bool) -> np.ndarray | None:
    """``timestamps`` given to :func:`save_traverse` as ``(N,)`` float64 seconds, or ValueError
    (not finite, going back in time, or nothing to write them into)."""
    if timestamps is None:
        return None
    if not written_somewhere:
        raise ValueError("timestamps are written into poses.csv or odometry.csv: pass positions or odometry too")
    times = np.asarray(timestamps, dtype=np.float64)
    if times.ndim != 1 or not np.isfinite(times).all():
        raise ValueError(f"timestamps must be (N,) finite seconds, got shape {times.shape}")
    if (np.diff(times) < 0).any():
        k = int(np.flatnonzero(np.diff(times) < 0)[0]) + 1
        raise ValueError(
            f"timestamps[{k}] = {float(times[k])!r} is before timestamps[{k - 1}] = {float(times[k - 1])!r}"
        )
    return times


def _every(times: np.ndarray | None, step: int) -> np.ndarray | None:
    return None if times is None else times[::step]


def _odometry_times(root: Path, names: Sequence[str]) -> np.ndarray | None:
    """The frames' times from ``root/odometry.csv``'s ``timestamp`` column, or None (no file, no
    column; a file that is not regular is left to the odometry's reader to name)."""
    file = root / ODOMETRY_FILE
    if not os.path.isfile(file):
        return None
    found = read_odometry_timestamps(file)
    if found is None:
        return None
    missing = [name for name in names if name not in found]
    if missing:
        raise DatasetError(
            f"{file} has a timestamp column but no row for image {missing[0]!r}"
            + (f" ({len(missing) - 1} more frames lack one)" if len(missing) > 1 else "")
        )
    return checked_timestamps([found[n][0] for n in names], [found[n][1] for n in names], file)


def _load_video(file: Path, frame_step: int, poses: Path | None) -> Traverse:
    count = video_frame_count(file)
    label = f"frame_{{:0{max(6, len(str(count)))}d}}"
    rate = video_frame_rate(file)
    if poses is None:
        frames = list(range(0, count, frame_step))
        times = None if rate is None else np.array(frames, dtype=np.float64) / rate
        return Traverse(
            root=file, names=[label.format(f) for f in frames], video=file, frame_indices=frames, timestamps=times
        )
    check_regular(poses, "poses file", DatasetError)
    rows, has_heading = read_pose_csv(poses, "frame")
    for row in rows:
        if int(row.key) >= count:
            raise DatasetError(f"{poses} line {row.line}: frame {row.key} is past the end of {file} ({count} frames)")
    rows = sorted((row for row in rows if int(row.key) % frame_step == 0), key=lambda row: int(row.key))
    if not rows:
        raise DatasetError(f"{poses}: no frame index is a multiple of frame_step={frame_step}")
    positions, headings = poses_from_rows(rows, has_heading)
    if rows[0].timestamp is not None:  # the CSV's times, else the video's frame times
        times = checked_timestamps(
            [r.timestamp for r in rows if r.timestamp is not None], [r.line for r in rows], poses
        )
    else:
        times = None if rate is None else np.array([int(r.key) for r in rows], dtype=np.float64) / rate
    return Traverse(
        root=file,
        names=[label.format(int(row.key)) for row in rows],
        positions=positions,
        headings=headings,
        video=file,
        frame_indices=[int(row.key) for row in rows],
        poses_file=poses,
        lines=[row.line for row in rows],
        timestamps=times,
    )


def load_traverse(
    path: PathLike,
    *,
    frame_step: int = 1,
    poses: PathLike | None = None,
    image_topic: str | None = None,
    odometry_topic: str | None = None,
    pose_topic: str | None = None,
    sync_tolerance: float = DEFAULT_SYNC_TOLERANCE_S,
) -> Traverse:
    """Opens a traverse: a folder (``images/`` + optional ``poses.csv``), a video file or a ROS bag.

    Only names, times and poses are read here; images are decoded lazily by
    :meth:`Traverse.read` and :meth:`Traverse.frames`. Every file named in ``poses.csv`` must exist.

    Args:
        path: the traverse folder, a video file (any suffix in :data:`VIDEO_SUFFIXES`, or any
            other file OpenCV can open as a video), or a ROS bag (a ROS 1 ``.bag``, a ROS 2 bag
            folder, a lone ``.mcap`` or ``.db3``; :mod:`nightloc.io.bag`).
        frame_step: keep every ``frame_step``-th frame: rows 0, k, 2k, ... of ``poses.csv`` (or of
            the sorted image list, or of a bag's image topic), or for a video the frames whose
            index is a multiple of k.
        poses: a poses CSV to use instead of ``path/poses.csv``; for a video, the CSV keyed by
            frame index (``frame,x,y[,heading]``). Without it a video has no poses. Either may
            hold a ``timestamp`` column (seconds), the frames' times.
        image_topic, odometry_topic, pose_topic: a bag's topics (default: the only one of each
            kind; ``odometry_topic`` may be ``/tf`` or ``/tf:PARENT:CHILD``).
        sync_tolerance: a bag's largest time (s) between a frame and the odometry or pose sample
            nearest to it.

    Raises:
        DatasetError: missing folder or files, unreadable video or bag, malformed CSV (naming file
            and line), a bag's topics that are missing, ambiguous or do not cover the frames.
    """
    root = Path(path)
    step = _check_step(frame_step)
    pose_path = None if poses is None else Path(poses)
    if bag_kind(root) is not None:
        if pose_path is not None:
            raise ValueError(f"{root} is a ROS bag: its poses come from its pose topic (pose_topic), not a CSV")
        log = load_bag(
            root,
            step,
            image_topic=image_topic,
            odometry_topic=odometry_topic,
            pose_topic=pose_topic,
            sync_tolerance=sync_tolerance,
        )
        return Traverse(
            root=root,
            names=log.names,
            positions=log.positions,
            headings=log.headings,
            bag=log.frames,
            timestamps=log.timestamps,
            motions=log.motions,
        )
    given = [name for name, value in (("image_topic", image_topic), ("odometry_topic", odometry_topic),
                                      ("pose_topic", pose_topic)) if value is not None]  # fmt: skip
    if given:
        raise with_cli_words(
            ValueError(f"{given[0]} applies to ROS bags; {root} is {path_kind(root)}"),
            f"--{given[0].replace('_', '-')} applies to ROS bags; {root} is {path_kind(root)}",
        )
    if root.is_dir():
        return _load_folder(root, step, pose_path)
    check_regular(root, "traverse", DatasetError)  # missing, a link loop, a FIFO, a device, ...
    if root.suffix.lower() in IMAGE_SUFFIXES or root.suffix.lower() == ".csv":
        raise DatasetError(f"{root} is a single file; a traverse is a folder ({_IMAGE_DIR}/ + {_POSE_FILE}) or a video")
    kind = path_kind(root)
    if root.suffix.lower() not in VIDEO_SUFFIXES and kind not in ("a video file", "a file of another kind"):
        raise DatasetError(f"{root} is {kind}, not a traverse ({_TRAVERSE_FORMS}){_swap_hint(kind)}")
    try:
        return _load_video(root, step, pose_path)
    except DatasetError:
        if root.suffix.lower() in VIDEO_SUFFIXES:
            raise
        raise DatasetError(
            f"{root} is not a traverse ({_TRAVERSE_FORMS}): it is not a folder, and OpenCV cannot read it as a video"
        ) from None


#: The forms a traverse takes, for error messages.
_TRAVERSE_FORMS = "a folder of images, a video or a ROS bag"


def _swap_hint(kind: str) -> str:
    return "; check the order of the arguments (a map comes before a traverse)" if kind == MAP else ""


# --------------------------------------------------------------------------------------------
# saving


def _checked_image(image: object, index: int) -> np.ndarray:
    return _validate.camera_frame(
        image,
        f"images[{index}]",
        dtype_hint="save uint8 images (numpy.clip(x, 0, 255).astype(numpy.uint8)) or uint16",
        shape_hint="",
    )


def _checked_names(names: Sequence[str] | None, image_format: str) -> list | None:
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


def _looks_like_traverse(folder: Path) -> bool:
    entries = {entry.name for entry in os.scandir(folder)}
    return _IMAGE_DIR in entries and entries <= {_IMAGE_DIR, _POSE_FILE, ODOMETRY_FILE}


def _checked_format(image_format: str) -> str:
    """The image files' suffix (no dot, lower case): one OpenCV writes and load_traverse reads."""
    fmt = str(image_format).lower().lstrip(".")
    if not fmt or not cv2.haveImageWriter(f"x.{fmt}"):
        raise ValueError(f"image_format {image_format!r} is not a format OpenCV can write (try 'png' or 'jpg')")
    if f".{fmt}" not in IMAGE_SUFFIXES:
        raise ValueError(
            f"image_format {image_format!r} is not read back by load_traverse; use one of png, jpg, bmp, tif"
        )
    return fmt


def _checked_motions(odometry: Sequence[object] | None, positions: np.ndarray | None) -> list | None:
    """The odometry as a list of motions, every one checked (one per position), or None."""
    if odometry is None:
        return None
    if isinstance(odometry, (str, bytes)) or not hasattr(odometry, "__len__"):
        raise TypeError("odometry must be a sequence of motions (one per image), e.g. a list of nightloc.RobotMotion")
    motions = list(odometry)
    odometry_values(motions)  # checks every motion before anything is written
    if positions is not None and len(motions) != len(positions):
        raise ValueError(f"{len(motions)} odometry rows but {len(positions)} positions")
    return motions


def _write_images(
    image_dir: Path, images: Iterable[np.ndarray], expected: int | None, file_names: list[str] | None, fmt: str
) -> list[str]:
    """Each image into ``image_dir`` (its name, or ``NNNNNN.<fmt>``), checked as it comes: the names written."""
    written: list = []
    for index, image in enumerate(images):
        if expected is not None and index >= expected:
            raise ValueError(f"more images than the {expected} positions/names given")
        image = _checked_image(image, index)
        name = file_names[index] if file_names is not None else None
        if name is None:
            name = f"{index:06d}.{fmt}"
        write_image_file(image_dir / name, image, index)
        written.append(name)
    return written


def save_traverse(
    path: PathLike,
    images: Iterable[np.ndarray],
    positions: object | None = None,
    headings: object | None = None,
    names: Sequence[str] | None = None,
    *,
    odometry: Sequence[object] | None = None,
    timestamps: Sequence[float] | np.ndarray | None = None,
    image_format: str = "png",
    overwrite: bool = False,
) -> Traverse:
    """Writes a traverse folder (``images/`` + ``poses.csv`` [+ ``odometry.csv``]) atomically and opens it.

    The folder is built in a temporary sibling and renamed into place at the end, so an error or
    an interruption never leaves a half-written traverse at ``path``. Images are streamed: an
    iterator of frames is written one at a time.

    Args:
        path: the folder to create.
        images: iterable of uint8 (or uint16) images, grey ``(H, W)`` or BGR ``(H, W, 3)``.
        positions: ``(N, 2)`` metres, or None for a route traverse (no ``poses.csv``).
        headings: ``(N,)`` radians (wrapped to (-pi, pi]), or None; needs positions.
        names: the N file names (default ``000000.<format>``, ``000001.<format>``, ...).
        odometry: N motions, the robot's odometry since the previous frame (element 0 is not
            used; None is written as zero): ``nightloc.RobotMotion`` (wheel odometry, written as
            ``image,forward,left,turn``) or ``MapDisplacement`` / ``(dx, dy)`` (``image,dx,dy``);
            written to ``odometry.csv`` (:mod:`nightloc.io.odometry_csv`).
        timestamps: N times in seconds (finite, never decreasing), or None: written as the
            ``timestamp`` column of ``poses.csv`` and ``odometry.csv`` (so it needs one of them).
        image_format: file suffix of the default names (``png``, ``jpg``, ``bmp``, ``tif``, ...).
        overwrite: replace an existing traverse folder at ``path`` (a folder holding anything
            else than ``images/``, ``poses.csv`` and ``odometry.csv`` is never replaced).

    The parent folder of ``path`` must exist (FileNotFoundError); a symbolic link at ``path`` is
    followed; another process saving to the same ``path`` makes this call raise
    BlockingIOError at once.

    Returns:
        The written :class:`Traverse`.
    """
    target = Path(path)
    fmt = _checked_format(image_format)
    pos, head = checked_poses(positions, headings)
    file_names = _checked_names(names, fmt)
    motions = _checked_motions(odometry, pos)
    times = _checked_times(timestamps, pos is not None or motions is not None)
    expected = len(pos) if pos is not None else (len(file_names) if file_names is not None else None)
    if pos is not None and file_names is not None and len(file_names) != len(pos):
        raise ValueError(f"{len(file_names)} names but {len(pos)} positions")
    with atomic_folder(target) as staging:  # one writer at a time; the parent folder must exist
        if target.exists():
            if not overwrite:
                raise with_cli_words(
                    FileExistsError(f"{target} exists; pass overwrite=True to replace it"),
                    f"{target} exists; pass --overwrite to replace it",
                )
            if not target.is_dir() or not _looks_like_traverse(target):
                raise FileExistsError(
                    f"{target} exists and is not a traverse folder (only images/, poses.csv and odometry.csv); "
                    f"refusing to replace it"
                )
        image_dir = staging / _IMAGE_DIR
        image_dir.mkdir()
        written = _write_images(image_dir, images, expected, file_names, fmt)
        if not written:
            raise ValueError("images is empty: a traverse needs at least one image")
        if expected is not None and len(written) != expected:
            raise ValueError(f"{len(written)} images but {expected} positions/names")
        if times is not None and len(times) != len(written):
            raise ValueError(f"{len(times)} timestamps but {len(written)} images")
        if pos is not None:
            write_pose_csv(staging / _POSE_FILE, written, pos, head, times)
        if motions is not None:
            if len(motions) != len(written):
                raise ValueError(f"{len(motions)} odometry rows but {len(written)} images")
            write_odometry_csv(staging / ODOMETRY_FILE, written, motions, timestamps=times)
    return load_traverse(target)
