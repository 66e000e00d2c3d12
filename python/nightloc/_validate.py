"""Input checks shared by the public API: clear errors, never a silent cast or copy."""

from __future__ import annotations

import functools
import os
from collections.abc import Sequence

import numpy as np

ShiftSpec = None | int | Sequence[int] | np.ndarray


def _describe(array: np.ndarray) -> str:
    return f"shape {array.shape}, dtype {array.dtype}"


def uint8_array(value: object, ndim: int, name: str) -> np.ndarray:
    """Returns ``value`` when it is a C-contiguous uint8 ndarray of rank ``ndim``.

    Raises TypeError for a non-array or another dtype and ValueError for another rank, an empty
    axis or a non-contiguous array, each naming what was expected and how to convert.
    """
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
    if array.min() < 0 or array.max() >= width:
        raise ValueError(
            f"shifts must lie in [0, {width}) for images {width} pixels wide, got {array.min()}..{array.max()}"
        )
    if np.unique(array).size != array.size:
        raise ValueError("shifts must not repeat a value")
    return np.ascontiguousarray(array, dtype=np.int32)


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

    An (H, W, 1) frame is returned as (H, W). Raises TypeError (not an array, another dtype) or
    ValueError (another shape, an empty axis) naming ``name``; ``dtype_hint`` and ``shape_hint``
    end the messages with how to fix the input for the calling function.
    """
    if not isinstance(image, np.ndarray):
        raise TypeError(f"{name} must be a numpy.ndarray (uint8 or uint16), got {type(image).__name__}")
    if image.dtype not in (np.uint8, np.uint16):
        raise TypeError(f"{name} has dtype {image.dtype}; {dtype_hint}")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] in (3, 4))):
        raise ValueError(f"{name} must be grey (H, W) or colour (H, W, 3|4), got shape {image.shape}{shape_hint}")
    if 0 in image.shape:
        raise ValueError(f"{name} is empty (shape {image.shape})")
    return image
