"""Downsampling building blocks of image preparation: exact area averaging and 16-bit equalization.

:func:`area_downsample` is computed by the compiled core for 8-bit frames (bit for bit the same as
:func:`area_downsample_opencv`, the OpenCV/numpy formulation that also serves 16-bit frames and
upsampling).
"""

from __future__ import annotations

import cv2
import numpy as np

from .. import _core

__all__ = ["area_downsample", "area_downsample_opencv", "equalize_hist16", "packed"]


def equalize_hist16(image: np.ndarray) -> np.ndarray:
    """Histogram equalization of a uint16 grey image to uint8, with ``cv2.equalizeHist``'s formula.

    ``lut[v] = round(255 * (cdf(v) - n_min) / (n - n_min))`` where ``n_min`` is the count of the
    darkest grey level present (which maps to 0); a flat image keeps its level (saturated to 255).
    """
    histogram = np.bincount(image.reshape(-1), minlength=65536)
    present = np.flatnonzero(histogram)
    darkest = int(present[0])
    total = image.size
    if histogram[darkest] == total:
        return np.full(image.shape, min(darkest, 255), dtype=np.uint8)
    scale = np.float32(255.0 / (total - histogram[darkest]))
    cumulative = np.cumsum(histogram) - histogram[darkest]
    lut = np.rint(cumulative.astype(np.float32) * scale)
    lut[:darkest] = 0
    lut = np.clip(lut, 0, 255).astype(np.uint8)
    return lut[image]


class _AreaSampler:
    """Where the output cell edges fall in the integral image of one input size.

    The integral image of a piecewise-constant image is bilinear inside each pixel, so the exact
    area sum over a cell with fractional edges is a bilinear interpolation of the integral image
    at the cell's four corners.
    """

    __slots__ = ("columns", "factor", "fx", "fy", "n_x", "n_y", "rows")

    def __init__(self, in_h: int, in_w: int, out_h: int, out_w: int):
        ys = np.arange(out_h + 1, dtype=np.float64) * (in_h / out_h)
        xs = np.arange(out_w + 1, dtype=np.float64) * (in_w / out_w)
        y0 = np.minimum(np.floor(ys).astype(np.intp), in_h - 1)
        x0 = np.minimum(np.floor(xs).astype(np.intp), in_w - 1)
        self.fy = (ys - y0)[:, None]
        self.fx = xs - x0
        self.rows = np.concatenate([y0, y0 + 1])[:, None]
        self.columns = np.concatenate([x0, x0 + 1])[None, :]
        self.n_y, self.n_x = out_h + 1, out_w + 1
        self.factor = (out_h * out_w) / (in_h * in_w)

    def means(self, integral: np.ndarray) -> np.ndarray:
        corners = integral[self.rows, self.columns].astype(np.float64)  # (2 n_y, 2 n_x)
        rows = corners[: self.n_y] * (1.0 - self.fy) + corners[self.n_y :] * self.fy
        edges = rows[:, : self.n_x] * (1.0 - self.fx) + rows[:, self.n_x :] * self.fx
        box = edges[1:, 1:] - edges[:-1, 1:] - edges[1:, :-1] + edges[:-1, :-1]
        return box * self.factor


_SAMPLERS: dict[tuple[int, int, int, int], _AreaSampler] = {}
#: Below this many input pixels cv2.resize is faster than the integral image (fixed numpy cost).
_INTEGRAL_MIN_PIXELS = 65536


def area_downsample(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """Area-average a grey uint8/uint16 image to ``(height, width)``, same dtype.

    Each output pixel is the mean of the input area it covers (fractional pixels weighted by
    their covered fraction), rounded to nearest. Integer factors, upsampling and small inputs
    use ``cv2.resize(..., INTER_AREA)``'s arithmetic; other factors an integral image (exact
    sums), faster than ``cv2.resize`` for camera-size frames (docs/preparation.md). uint8 images that
    are not upsampled are computed by the compiled core (the same bytes as
    :func:`area_downsample_opencv`).
    """
    in_h, in_w = image.shape
    if image.dtype == np.uint8 and in_h >= height and in_w >= width and packed(image):
        settings = _core.PrepareSettings()
        settings.equalize = "none"
        settings.width, settings.height = width, height
        settings.patch_normalize = False
        return _core.prepare_frame(image, "grey", settings)
    return area_downsample_opencv(image, width, height)


def area_downsample_opencv(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """:func:`area_downsample` with OpenCV and numpy only (the reference for the core's).

    ``cv2.resize(..., INTER_AREA)`` for integer factors, upsampling and inputs below 65 536
    pixels; an integral image (``cv2.integral``) and float64 means rounded by ``numpy.rint``
    otherwise.
    """
    in_h, in_w = image.shape
    if (in_h, in_w) == (height, width):
        return np.ascontiguousarray(image)
    small = in_h * in_w < _INTEGRAL_MIN_PIXELS
    if small or in_h < height or in_w < width or (in_h % height == 0 and in_w % width == 0):
        return cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)
    key = (in_h, in_w, height, width)
    sampler = _SAMPLERS.get(key)
    if sampler is None:
        if len(_SAMPLERS) > 64:
            _SAMPLERS.clear()
        sampler = _SAMPLERS[key] = _AreaSampler(in_h, in_w, height, width)
    exact_int32 = image.dtype == np.uint8 and in_h * in_w * 255 < 2**31
    integral = cv2.integral(image, sdepth=cv2.CV_32S if exact_int32 else cv2.CV_64F)
    means = sampler.means(integral)
    top = 255 if image.dtype == np.uint8 else 65535
    return np.clip(np.rint(means), 0, top).astype(image.dtype)


def packed(frame: np.ndarray) -> bool:
    """Whether a uint8 (H, W) or (H, W, C) array has packed pixels and rows going forward (the core's layout)."""
    strides = frame.strides
    pixel = 1 if frame.ndim == 2 else frame.shape[2]
    if strides[1] != pixel or (frame.ndim == 3 and strides[2] != 1):
        return False
    return frame.shape[0] == 1 or strides[0] >= frame.shape[1] * pixel
