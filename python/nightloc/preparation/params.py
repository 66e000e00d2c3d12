"""Preparation parameters: how camera frames become the small normalized images the core matches."""

from __future__ import annotations

import dataclasses
from typing import Any, Literal

from .. import _core
from .._validate import MAX_CLAHE_TILES
from ..config import params_section
from ..schema import ABOVE_0, CoreTable, core_names, own_field

__all__ = ["PreparationParams"]

CropValue = int | float

#: The core's ``PrepareSettings`` table (nightloc/prepare.hpp): the one place the defaults, ranges,
#: units and docs of the fields the core holds are written.
PREPARE_SETTINGS = CoreTable(_core.PrepareSettings)
_PREPARE = PREPARE_SETTINGS


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

    width: int = _PREPARE.field("width")
    height: int = _PREPARE.field("height")
    radius: int = _PREPARE.field("radius")
    wrap: bool = _PREPARE.field("wrap")
    equalize: Literal["global", "clahe", "none"] = _PREPARE.field("equalize")
    clahe_clip_limit: float = own_field(2.0, range=ABOVE_0)
    clahe_tiles: tuple[int, int] = (8, 8)
    crop: tuple[CropValue, CropValue, CropValue, CropValue] = own_field((0, 0, 0, 0), unit="pixels or fractions")
    patch_normalize: bool = _PREPARE.field("patch_normalize")
    scale: float = _PREPARE.field("scale")
    channel_order: Literal["bgr", "rgb"] = "bgr"

    def validate(self) -> None:
        """The rules the table cannot say (each field's range is checked on construction): the
        core's ``validate()`` (the size), CLAHE's tiles and the crop's fractions (the core takes
        pixels)."""
        self.core_settings().validate()
        if min(self.clahe_tiles) < 1 or max(self.clahe_tiles) > MAX_CLAHE_TILES:
            raise ValueError(
                f"clahe_tiles must be 1..{MAX_CLAHE_TILES} in both directions (MAX_CLAHE_TILES; OpenCV keeps a "
                f"histogram per tile), got {self.clahe_tiles}"
            )
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

    def core_settings(
        self, crop: tuple[int, int, int, int] = (0, 0, 0, 0), patch_normalize: bool | None = None
    ) -> _core.PrepareSettings:
        """The core's ``PrepareSettings`` (what ``prepare_frame`` takes): this class's fields with
        ``crop`` in pixels (top, bottom, left, right; ``Preparer.crop_pixels`` resolves the
        fractions for a frame) and ``patch_normalize`` (None: this class's)."""
        settings = _core.PrepareSettings()
        for name, core_name in _CORE_FIELDS.items():
            setattr(settings, core_name, getattr(self, name))
        settings.crop_top, settings.crop_bottom, settings.crop_left, settings.crop_right = crop
        if patch_normalize is not None:
            settings.patch_normalize = patch_normalize
        return settings

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


#: The fields of :class:`PreparationParams` the core's settings hold, by their name there.
_CORE_FIELDS = core_names(PreparationParams)
