"""Preparation parameters: how camera frames become the small normalized images the core matches."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Literal

from .. import _core
from .._validate import MAX_CLAHE_TILES
from ..config import params_section
from .normalize import DEFAULT_PATCH_SCALE, MAX_PATCH_RADIUS

__all__ = ["PreparationParams"]

CropValue = int | float


@params_section("preparation")
@dataclasses.dataclass(frozen=True)
class PreparationParams:
    """How camera frames become the small normalized images the core matches (paper Table II).

    Attributes:
        width: Rx, columns of the prepared image (48). For a panorama, one column spans
            360/width degrees.
        height: Ry, rows of the prepared image (24).
        radius: P, patch-normalization window radius in pixels (4: a 9x9 window).
        wrap: True for 360-degree panoramas: the window wraps around horizontally and matching
            searches every column shift; False for forward cameras (window clipped at the
            borders, matching at shift 0 only).
        equalize: histogram equalization of the full-resolution grey image: ``"global"``
            (``cv2.equalizeHist``), ``"clahe"`` (contrast-limited adaptive) or ``"none"``.
        clahe_clip_limit: CLAHE contrast limit (OpenCV's clipLimit).
        clahe_tiles: CLAHE tile grid (columns, rows), 1..256 each (``MAX_CLAHE_TILES``).
        crop: (top, bottom, left, right) removed before anything else; ints are pixels, floats
            in [0, 1) fractions of the frame's height (top, bottom) or width (left, right).
        patch_normalize: apply patch normalization (eq. 1); False keeps the downsampled grey.
        scale: quantization gain of patch normalization (grey levels per standard deviation).
        channel_order: ``"bgr"`` (OpenCV, :meth:`Traverse.read`) or ``"rgb"`` for colour input.
    """

    width: int = 48
    height: int = 24
    radius: int = 4
    wrap: bool = True
    equalize: Literal["global", "clahe", "none"] = "global"
    clahe_clip_limit: float = 2.0
    clahe_tiles: tuple[int, int] = (8, 8)
    crop: tuple[CropValue, CropValue, CropValue, CropValue] = (0, 0, 0, 0)
    patch_normalize: bool = True
    scale: float = DEFAULT_PATCH_SCALE
    channel_order: Literal["bgr", "rgb"] = "bgr"

    def validate(self) -> None:
        """Checks ranges (called on construction); raises ValueError naming the field."""
        for name in ("width", "height"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1 pixel, got {getattr(self, name)}")
        if self.width * self.height > _core.MAX_IMAGE_PIXELS:
            raise ValueError(
                f"width x height = {self.width}x{self.height} is too large: prepared images hold at most "
                f"{_core.MAX_IMAGE_PIXELS} pixels (the paper uses 48x24)"
            )
        if not 0 <= self.radius <= MAX_PATCH_RADIUS:
            raise ValueError(f"radius must be in [0, {MAX_PATCH_RADIUS}], got {self.radius}")
        if not (math.isfinite(self.clahe_clip_limit) and self.clahe_clip_limit > 0):
            raise ValueError(f"clahe_clip_limit must be a positive number, got {self.clahe_clip_limit}")
        if min(self.clahe_tiles) < 1 or max(self.clahe_tiles) > MAX_CLAHE_TILES:
            raise ValueError(
                f"clahe_tiles must be 1..{MAX_CLAHE_TILES} in both directions (MAX_CLAHE_TILES; OpenCV keeps a "
                f"histogram per tile), got {self.clahe_tiles}"
            )
        if not (math.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"scale must be a positive number, got {self.scale}")
        for side, value in zip(("top", "bottom", "left", "right"), self.crop):
            if isinstance(value, float):
                if not 0.0 <= value < 1.0:
                    raise ValueError(
                        f"crop {side} = {value}: a float is a fraction in [0, 1); write pixels as an integer"
                    )
            elif value < 0:
                raise ValueError(f"crop {side} = {value} pixels must be >= 0")
        for first, second, axis in ((0, 1, "height"), (2, 3, "width")):
            a, b = self.crop[first], self.crop[second]
            if isinstance(a, float) and isinstance(b, float) and a + b >= 1.0:
                raise ValueError(f"crop removes the whole {axis}: fractions {a} + {b} >= 1")

    @property
    def shifts(self) -> list | None:
        """Column shifts to search when matching: None (all) for panoramas, ``[0]`` otherwise."""
        return None if self.wrap else [0]

    def differences(self, other: PreparationParams) -> dict[str, tuple[Any, Any]]:
        """Fields whose values differ: name -> (self's value, other's value)."""
        return {
            field.name: (getattr(self, field.name), getattr(other, field.name))
            for field in dataclasses.fields(self)
            if getattr(self, field.name) != getattr(other, field.name)
            or type(getattr(self, field.name)) is not type(getattr(other, field.name))
        }
