"""Parameters of route mode and its presets.

:class:`RouteParams` is the TOML table ``[route]`` (see :mod:`nightloc.params`); OpenSeqSLAM's
parameter names are given in brackets. Two presets:

* ``"openseqslam"`` reproduces OpenSeqSLAM's defaults bit for bit (images used at their own size,
  Octave's ``rgb2gray``, 8x8 block normalization, D divided by the number of references,
  enhancement R = 10, ds = 10, v = 0.8 ... 1.2, Rwindow = 10, centred trajectories);
* ``"nightloc"`` (the default) prepares images the paper's way (grey, histogram equalization,
  area downsample to 48x24, patch normalization with radius 4, no wrap for a forward camera,
  see :class:`~nightloc.params.PreparationParams`) and scores mean absolute differences per
  pixel; enhancement and search as OpenSeqSLAM.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

from .. import _core
from ..config import params_section
from ..preparation.params import PreparationParams

__all__ = ["PRESETS", "RouteParams", "default_preparation", "resolve_params", "route_preset"]


@params_section("route")
@dataclasses.dataclass(frozen=True)
class RouteParams:
    """Route mode (1D SeqSLAM) parameters.

    Attributes:
        preparation: ``"openseqslam"``: grey with Octave's ``rgb2gray`` (BT.601, rounded half away
            from zero), images kept at their own size, ``block_side`` block normalization;
            ``"nightloc"``: the paper's preparation with a :class:`PreparationParams`.
        block_side: block size of OpenSeqSLAM's normalization, pixels [normalization.sideLength].
        divisor: difference-matrix scale: ``"references"`` divides the sum of absolute
            differences by the number of reference images (OpenSeqSLAM), ``"pixels"`` by the
            image size (mean absolute difference in grey levels).
        circular_shifts: search every circular column shift (360-degree panoramas) instead of
            shift 0 only (forward cameras).
        enhance_radius: contrast enhancement over references i-radius .. i+radius [R/2].
        ds: sequence length in frames [matching.ds]. Centred mode rounds it up to even and uses
            ds+1 frames; causal mode uses ds frames ending at the query.
        vmin, vmax: slowest and fastest speeds, references per query frame [matching.vmin,
            vmax]; the speeds searched are (vmin*ds : 1 : vmax*ds) / ds.
        uniqueness_radius: the second-best trajectory excludes anchors within this many
            references of the best [Rwindow/2].
        mode: ``"centred"`` (OpenSeqSLAM: needs ds/2 future frames) or ``"causal"``
            (trajectories end at the current frame; usable online).
    """

    preparation: Literal["nightloc", "openseqslam"] = "nightloc"
    block_side: int = 8
    divisor: Literal["pixels", "references"] = "pixels"
    circular_shifts: bool = False
    enhance_radius: int = 5
    ds: int = 10
    vmin: float = 0.8
    vmax: float = 1.2
    uniqueness_radius: int = 5
    mode: Literal["centred", "causal"] = "centred"

    def validate(self) -> None:
        """Checks ranges (called on construction); raises ValueError naming the field."""
        if self.block_side < 2:
            raise ValueError(f"block_side must be >= 2 pixels, got {self.block_side}")
        if self.enhance_radius < 1:
            raise ValueError(f"enhance_radius must be >= 1 reference, got {self.enhance_radius}")
        if not 2 <= self.ds <= 100000:
            raise ValueError(f"ds must be a sequence length in [2, 100000] frames, got {self.ds}")
        for name in ("vmin", "vmax"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 < value <= 1000):
                raise ValueError(f"{name} must be a speed in (0, 1000] references per frame, got {value}")
        if self.vmin > self.vmax:
            raise ValueError(f"vmin ({self.vmin}) must not exceed vmax ({self.vmax})")
        ds = self.effective_ds
        speeds = math.floor(self.vmax * ds - self.vmin * ds) + 1
        frames = ds + 1 if self.mode == "centred" else ds
        if speeds * frames > _core.MAX_TRAJECTORY_PLAN_ENTRIES:
            raise ValueError(
                f"{speeds} speeds (vmin {self.vmin} .. vmax {self.vmax} at ds {self.ds}) x {frames} frames is too "
                f"large a search (at most {_core.MAX_TRAJECTORY_PLAN_ENTRIES:.0f}); narrow vmin..vmax or shorten ds"
            )
        if self.uniqueness_radius < 0:
            raise ValueError(f"uniqueness_radius must be >= 0, got {self.uniqueness_radius}")

    @property
    def effective_ds(self) -> int:
        """The sequence length the search uses (centred mode: rounded up to even)."""
        return self.ds + self.ds % 2 if self.mode == "centred" else self.ds

    @property
    def shifts(self) -> list | None:
        """Column shifts searched by the difference matrix: None (all) or ``[0]``."""
        return None if self.circular_shifts else [0]

    @property
    def enhance_offset(self) -> str:
        """What follows the z-scores: ``"global_min"`` (centred, OpenSeqSLAM: minus the minimum
        of the whole matrix) or ``"bound"`` (causal: plus the largest possible |z|,
        ``2r/sqrt(2r+1)``, which needs no future frames)."""
        return "global_min" if self.mode == "centred" else "bound"


#: Preset name -> parameters.
PRESETS = {
    "nightloc": RouteParams(),
    "openseqslam": RouteParams(preparation="openseqslam", divisor="references"),
}


def route_preset(name: str) -> RouteParams:
    """The :class:`RouteParams` of a preset (``"nightloc"`` or ``"openseqslam"``)."""
    if name not in PRESETS:
        raise ValueError(f"unknown route preset {name!r}; choose one of {', '.join(sorted(PRESETS))}")
    return PRESETS[name]


def resolve_params(params: RouteParams | str | None = None, **overrides: object) -> RouteParams:
    """``params`` (a :class:`RouteParams`, a preset name, or None for ``"nightloc"``) with the
    given fields replaced (``None`` values are ignored)."""
    if params is None:
        base = PRESETS["nightloc"]
    elif isinstance(params, str):
        base = route_preset(params)
    elif isinstance(params, RouteParams):
        base = params
    else:
        raise TypeError(f"params must be a RouteParams or a preset name, got {type(params).__name__}")
    changes = {key: value for key, value in overrides.items() if value is not None}
    unknown = set(changes) - {field.name for field in dataclasses.fields(RouteParams)}
    if unknown:
        raise TypeError(f"unknown route parameter(s): {', '.join(sorted(unknown))}")
    return dataclasses.replace(base, **changes) if changes else base


def default_preparation(params: RouteParams) -> PreparationParams:
    """The paper's preparation for the ``"nightloc"`` preset: 48x24, global equalization, patch
    normalization with radius 4, the window wrapping only when circular shifts are searched."""
    return PreparationParams(wrap=params.circular_shifts)
