"""Normalization of prepared images: the paper's patch normalization (eq. 1) and OpenSeqSLAM's
block normalization, both computed by the compiled core.

Images are ``uint8``: one image ``(height, width)`` or a stack ``(n, height, width)``,
C-contiguous; a wrong dtype, rank or size raises TypeError/ValueError, nothing is cast.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from .._validate import image_or_stack

__all__ = ["DEFAULT_PATCH_SCALE", "MAX_PATCH_RADIUS", "block_normalize", "patch_normalize"]

#: Quantization gain of :func:`patch_normalize`: output = clip(floor(128 + scale*z + 0.5), 0, 255).
DEFAULT_PATCH_SCALE: float = float(_core.DEFAULT_PATCH_SCALE)
#: Largest patch-normalization radius (the window sums stay exact in 64-bit integers).
MAX_PATCH_RADIUS: int = int(_core.MAX_PATCH_RADIUS)


def patch_normalize(
    images: np.ndarray, radius: int = 4, wrap: bool = True, scale: float = DEFAULT_PATCH_SCALE
) -> np.ndarray:
    """Patch normalization, the paper's eq. (1), quantized back to uint8.

    Every pixel becomes ``z = (I - mu) / sigma`` with ``mu``, ``sigma`` the mean and population
    standard deviation of the ``(2*radius+1)**2`` window around it, then
    ``clip(floor(128 + scale*z + 0.5), 0, 255)``. A flat window gives 128 (never NaN).

    Args:
        images: ``(H, W)`` or ``(N, H, W)`` uint8.
        radius: window radius in pixels (the paper's P = 4: a 9x9 window), at most
            :data:`MAX_PATCH_RADIUS`.
        wrap: True for 360-degree panoramas: the window wraps around horizontally, so the result
            commutes with circular column shifts; False clips the window at all borders
            (forward-facing cameras). Rows are always clipped.
        scale: grey levels per standard deviation of the output.

    Returns:
        uint8 array of the same shape.
    """
    array = image_or_stack(images, "images")
    if isinstance(radius, bool) or not isinstance(radius, (int, np.integer)) or not 0 <= radius <= MAX_PATCH_RADIUS:
        raise ValueError(f"radius must be an int in [0, {MAX_PATCH_RADIUS}], got {radius!r}")
    if isinstance(scale, bool) or not isinstance(scale, (int, float, np.integer, np.floating)):
        raise TypeError(f"scale must be a number (grey levels per standard deviation), got {type(scale).__name__}")
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale must be a positive finite number, got {scale!r}")
    stack = array[np.newaxis] if array.ndim == 2 else array
    out = _core.patch_normalize(stack, int(radius), bool(wrap), float(scale))
    return out[0] if array.ndim == 2 else out


def block_normalize(images: np.ndarray, side: int = 8) -> np.ndarray:
    """OpenSeqSLAM's patch normalization (its mode 1), bit-exact with the Matlab original.

    Each full, non-overlapping ``side x side`` block becomes ``127 + round(z)`` (z with the N-1
    standard deviation, round half away from zero, saturated to 0..255); a flat block becomes 0
    (Matlab's ``uint8(NaN)``); the incomplete blocks at the right and bottom borders keep their
    input values.

    Args:
        images: ``(H, W)`` or ``(N, H, W)`` uint8.
        side: block side in pixels (OpenSeqSLAM's default 8).
    """
    array = image_or_stack(images, "images")
    if isinstance(side, bool) or not isinstance(side, (int, np.integer)) or not 2 <= side < 2**31:
        raise ValueError(f"side must be an int >= 2 (pixels), got {side!r}")
    stack = array[np.newaxis] if array.ndim == 2 else array
    out = _core.block_normalize(stack, int(side))
    return out[0] if array.ndim == 2 else out
