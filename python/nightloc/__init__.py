"""nightloc: 2D visual place recognition at night for small robots.

Implements Mount & Milford, "2D Visual Place Recognition for Domestic Service Robots at Night"
(2016): tiny contrast-normalized panoramas matched rotation-invariantly against a day-time map,
with a compiled SIMD core. Quick start::

    import nightloc
    prepared = nightloc.patch_normalize(images)          # (N, 24, 48) uint8 panoramas
    result = nightloc.match(prepared[3], prepared)       # best reference, scores, headings
    scores, shifts = nightloc.difference_matrix(queries, prepared)
"""

from __future__ import annotations

from ._core import __version__
from .errors import DatasetError, MapFormatError, NightlocError
from .matching import (
    DEFAULT_PATCH_SCALE,
    MatchResult,
    block_normalize,
    difference_matrix,
    match,
    patch_normalize,
    rotational_sad,
    shifts_to_headings,
)
from .simd import available_simd_backends, set_simd_backend, simd_backend, use_simd_backend
from .params import PreparationParams, load_params, save_params
from .preparation import Preparer, prepare
from .reference_map import ReferenceMap
from .traverse import Traverse, load_traverse, save_traverse
from . import route
from .route import RouteLocalizer, RouteParams
from .localizer import Estimate, LocalizationParams, Localizer
from .odometry import MapDisplacement, RobotMotion

__all__ = [
    "__version__",
    "DEFAULT_PATCH_SCALE",
    "DatasetError",
    "MapFormatError",
    "MatchResult",
    "NightlocError",
    "available_simd_backends",
    "block_normalize",
    "difference_matrix",
    "match",
    "patch_normalize",
    "rotational_sad",
    "set_simd_backend",
    "shifts_to_headings",
    "simd_backend",
    "use_simd_backend",
    "Traverse",
    "load_traverse",
    "save_traverse",
    "PreparationParams",
    "load_params",
    "save_params",
    "Preparer",
    "prepare",
    "ReferenceMap",
    "route",
    "RouteLocalizer",
    "RouteParams",
    "Localizer",
    "LocalizationParams",
    "Estimate",
    "MapDisplacement",
    "RobotMotion",
]
