"""Input checks shared by the public API: clear errors, never a silent cast or copy; and the
bounds on every size and number that enters nightloc.

Bounds (each error message names its constant):

============================  =================================================================
``MAX_COORDINATE_M``          positions, margins, odometry steps, radii and tolerances: finite
                              and below 1e8 m in magnitude (UTM northings reach 1e7 m, Web
                              Mercator 2e7 m; at 1e8 m float64 still resolves 15 nm)
``MAX_GRID_CELLS``            heat-map and belief grids: at most 4 million cells
``MAX_SEQUENCE_CELLS``        a sequence's frames x grid cells (float32 each): 2**27 (512 MiB)
``MAX_CLAHE_TILES``           CLAHE tiles along each axis: 256
``MAX_CAMERA_RAYS``           synthetic panoramas: pixels x oversampling, 2**21 rays per frame
``MAX_CAMERA_SIDE``           synthetic panoramas: at most 8192 pixels wide or high
``MAX_REPEATS``               noise draws per noise model in an evaluation: 1000
``MAX_THREADS``               worker threads of a call: 1024
``MAX_MAP_EXPANSION``         a map file's arrays: at most 16 x the file's size (+ 1 MiB)
``MAX_PARAMS_FILE_BYTES``     a TOML parameter file: 1 MiB
============================  =================================================================

Defined elsewhere: ``nightloc.localization.localizer.MAX_SEQ_LEN`` (1000 frames),
``nightloc.preparation.MAX_PATCH_RADIUS`` and ``nightloc._core.MAX_IMAGE_PIXELS`` (prepared
images), ``nightloc._core.MAX_TRAJECTORY_PLAN_ENTRIES`` (route-mode search).
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import threading
from collections.abc import Iterator, Sequence

import numpy as np

ShiftSpec = None | int | Sequence[int] | np.ndarray

# --------------------------------------------------------------------------------------------
# bounds (see the module docstring)

MAX_COORDINATE_M = 1e8
_COORDINATE_TEXT = "1e8"  # MAX_COORDINATE_M as messages write it
MAX_GRID_CELLS = 4_000_000
MAX_SEQUENCE_CELLS = 1 << 27
MAX_CLAHE_TILES = 256
MAX_CAMERA_RAYS = 1 << 21
MAX_CAMERA_SIDE = 8192
MAX_REPEATS = 1000
MAX_MAP_EXPANSION = 16
MAX_PARAMS_FILE_BYTES = 1 << 20


def not_masked(value: object, name: str) -> None:
    """Raises TypeError for a numpy masked array: its mask would be silently ignored."""
    if isinstance(value, np.ma.MaskedArray):
        raise TypeError(
            f"{name} is a numpy masked array; nightloc would ignore its mask: pass numpy.ma.filled({name}, value) "
            f"or the rows without masked entries"
        )


def metres(value: object, name: str, *, minimum: float = -MAX_COORDINATE_M) -> float:
    """A distance or coordinate in metres: a real number, finite, at least ``minimum`` and below
    :data:`MAX_COORDINATE_M` in magnitude; raises TypeError/ValueError naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number of metres, got {type(value).__name__}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number of metres, got {number}")
    if not (minimum <= number and abs(number) < MAX_COORDINATE_M):
        low = f"-{_COORDINATE_TEXT}" if minimum == -MAX_COORDINATE_M else f"{minimum:g}"
        raise ValueError(f"{name} = {number:g} m is outside [{low}, {_COORDINATE_TEXT}) m (MAX_COORDINATE_M)")
    return number


def coordinates(values: np.ndarray, name: str) -> None:
    """Raises ValueError naming the first row of ``values`` (float64, any shape ``(N, ...)``)
    that is NaN, infinite or reaches :data:`MAX_COORDINATE_M` in magnitude."""
    bad = ~np.isfinite(values) | (np.abs(values) >= MAX_COORDINATE_M)
    if bad.any():
        row = int(np.argwhere(bad)[0, 0])
        shown = values[row].tolist()
        finite = np.isfinite(values[row]).all()
        what = f"beyond {_COORDINATE_TEXT} m" if finite else "not finite (NaN or infinite)"
        raise ValueError(
            f"{name}[{row}] = {shown} is {what}; coordinates must be finite metres within {_COORDINATE_TEXT} m "
            f"of the origin (MAX_COORDINATE_M)"
        )


def _describe(array: np.ndarray) -> str:
    return f"shape {array.shape}, dtype {array.dtype}"


def uint8_array(value: object, ndim: int, name: str) -> np.ndarray:
    """Returns ``value`` when it is a C-contiguous uint8 ndarray of rank ``ndim``.

    Raises TypeError for a non-array or another dtype and ValueError for another rank, an empty
    axis or a non-contiguous array, each naming what was expected and how to convert.
    """
    not_masked(value, name)
    if not isinstance(value, np.ndarray):
        raise TypeError(
            f"{name} must be a numpy.ndarray of dtype uint8, got {type(value).__name__}; "
            f"convert with numpy.asarray(x, dtype=numpy.uint8) after checking the value range"
        )
    if value.dtype != np.uint8:
        hint = (
            "scale floats in [0, 1] by 255 and round, or clip and cast integers: "
            "numpy.clip(x, 0, 255).astype(numpy.uint8)"
        )
        raise TypeError(f"{name} must have dtype uint8, got {value.dtype} ({hint})")
    if value.ndim != ndim:
        what = {2: "(height, width)", 3: "(n_images, height, width)"}[ndim]
        extra = ""
        if ndim == 3 and value.ndim == 2:
            extra = "; for a single image use image[numpy.newaxis]"
        elif ndim == 2 and value.ndim == 3 and value.shape[0] == 1:
            extra = "; for a stack of one image use stack[0]"
        raise ValueError(f"{name} must be {ndim}-D {what}, got {_describe(value)}{extra}")
    if 0 in value.shape:
        raise ValueError(f"{name} is empty ({_describe(value)}): it needs at least one image of at least 1x1 pixel")
    if not value.flags.c_contiguous:
        raise ValueError(f"{name} must be C-contiguous; pass numpy.ascontiguousarray({name})")
    return value


def image_or_stack(value: object, name: str) -> np.ndarray:
    """A (H, W) or (N, H, W) uint8 array, checked as by :func:`uint8_array`."""
    ndim = value.ndim if isinstance(value, np.ndarray) and value.ndim in (2, 3) else 3
    return uint8_array(value, ndim, name)


def same_image_size(a: np.ndarray, b: np.ndarray, a_name: str, b_name: str) -> None:
    if a.shape[-2:] != b.shape[-2:]:
        raise ValueError(
            f"{a_name} images are {a.shape[-2]}x{a.shape[-1]} (height x width) but {b_name} images are "
            f"{b.shape[-2]}x{b.shape[-1]}: prepare both with the same parameters"
        )


@functools.lru_cache(maxsize=64)
def _all_shifts(width: int) -> np.ndarray:
    shifts = np.arange(width, dtype=np.int32)
    shifts.setflags(write=False)
    return shifts


def shift_list(shifts: ShiftSpec, width: int) -> np.ndarray:
    """The int32 shift list for ``shifts`` (None: all 0..width-1), checked for range and repeats."""
    if shifts is None:
        return _all_shifts(width)
    array = np.asarray(shifts)
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1 or array.size == 0:
        raise ValueError(f"shifts must be a non-empty 1-D sequence of column shifts, got shape {array.shape}")
    if array.dtype.kind not in "iu":
        raise TypeError(f"shifts must be integers, got dtype {array.dtype}")
    values = array.tolist()  # Python ints: cheaper than numpy reductions for the usual short lists
    low, high = min(values), max(values)
    if low < 0 or high >= width:
        raise ValueError(f"shifts must lie in [0, {width}) for images {width} pixels wide, got {low}..{high}")
    if len(set(values)) != len(values):
        raise ValueError("shifts must not repeat a value")
    return np.ascontiguousarray(array, dtype=np.int32)


WindowSpec = None | tuple[int, int] | Sequence[int]


def shift_window(window: WindowSpec, name: str = "shift_window") -> tuple[int, int]:
    """``(columns, rows)`` of a translation window: None is ``(0, 0)``; two ints >= 0. Sizes
    against the images are checked by the core (an offset must be smaller than the image)."""
    if window is None:
        return (0, 0)
    if isinstance(window, (str, bytes)) or not isinstance(window, (Sequence, np.ndarray)) or len(window) != 2:
        raise TypeError(f"{name} must be a pair (columns, rows) of ints >= 0, got {window!r}")
    values = []
    for value in window:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be a pair (columns, rows) of ints >= 0, got {window!r}")
        if value < 0:
            raise ValueError(f"{name} must be a pair (columns, rows) of ints >= 0, got {tuple(window)!r}")
        values.append(int(value))
    return (values[0], values[1])


@functools.lru_cache(maxsize=1)
def _usable_cores() -> int:
    """Cores this process may run on (looked up once: it is a system call)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


#: Most worker threads a call may ask for (the core starts at most one per task anyway).
MAX_THREADS = 1024


def thread_count(threads: int | None) -> int:
    """``threads`` checked (1 .. :data:`MAX_THREADS`), or every core this process may run on when None."""
    if threads is None:
        return _usable_cores()
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)):
        raise TypeError(f"threads must be an int or None, got {type(threads).__name__}")
    if not 1 <= threads <= MAX_THREADS:
        raise ValueError(f"threads must be in [1, {MAX_THREADS}], got {threads}")
    return int(threads)


def camera_frame(image: object, name: str, dtype_hint: str, shape_hint: str) -> np.ndarray:
    """A camera frame: uint8/uint16 ndarray, (H, W) grey or (H, W, 3|4) colour, not empty.

    An (H, W, 1) frame is returned as (H, W), and so is an (H, W, 2) grey + alpha frame (the
    alpha channel dropped, as for BGRA). Raises TypeError (not an array, a masked array, another
    dtype) or ValueError (another shape, an empty axis) naming ``name``; ``dtype_hint`` and
    ``shape_hint`` end the messages with how to fix the input for the calling function.
    """
    not_masked(image, name)
    if not isinstance(image, np.ndarray):
        raise TypeError(f"{name} must be a numpy.ndarray (uint8 or uint16), got {type(image).__name__}")
    if image.dtype not in (np.uint8, np.uint16):
        raise TypeError(f"{name} has dtype {image.dtype}; {dtype_hint}")
    if image.ndim == 3 and image.shape[2] in (1, 2):  # grey, or grey + alpha
        image = image[:, :, 0]
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] in (3, 4))):
        raise ValueError(f"{name} must be grey (H, W) or colour (H, W, 3|4), got shape {image.shape}{shape_hint}")
    if 0 in image.shape:
        raise ValueError(f"{name} is empty (shape {image.shape})")
    return image


class StreamGuard:
    """Refuses concurrent calls into a stateful stream (a localizer): ``with guard("update"):``
    raises RuntimeError when another thread is inside. Copies and pickles get a fresh lock."""

    def __init__(self, owner: str):
        self._owner = owner
        self._lock = threading.Lock()

    def __reduce__(self) -> tuple:
        return (StreamGuard, (self._owner,))

    @contextlib.contextmanager
    def __call__(self, what: str) -> Iterator[None]:
        if not self._lock.acquire(blocking=False):
            raise RuntimeError(
                f"{self._owner}.{what} was called while another thread is using this {self._owner}; it is one "
                f"stream of frames, so the order of the frames would be a race: use one {self._owner} per thread"
            )
        try:
            yield
        finally:
            self._lock.release()
