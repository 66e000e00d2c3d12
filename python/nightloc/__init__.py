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

from . import mapping, route  # mapping registers the [teach] parameter table (GTSAM loads on use)
from ._core import __version__
from .config import load_params, save_params
from .errors import DatasetError, DatasetWarning, MapFormatError, NightlocError, NightlocWarning
from .experience import LearningParams, learn, localize_night
from .io import Traverse, load_traverse, save_traverse
from .localization import (
    Estimate,
    FilterParams,
    LocalizationParams,
    Localizer,
    MapDisplacement,
    NoiseModel,
    RobotMotion,
    traverse_odometry,
)
from .mapping.reference_map import ReferenceMap
from .matching import (
    MatchResult,
    available_simd_backends,
    difference_matrix,
    match,
    rotational_sad,
    set_simd_backend,
    shifts_to_headings,
    simd_backend,
    use_simd_backend,
)
from .motion.odometry import WHEEL_ODOMETRY_NOISE
from .preparation import DEFAULT_PATCH_SCALE, PreparationParams, Preparer, block_normalize, patch_normalize, prepare
from .route import RouteLocalizer, RouteParams

__all__ = [
    "DEFAULT_PATCH_SCALE",
    "WHEEL_ODOMETRY_NOISE",
    "DatasetError",
    "DatasetWarning",
    "Estimate",
    "FilterParams",
    "LearningParams",
    "LocalizationParams",
    "Localizer",
    "MapDisplacement",
    "MapFormatError",
    "MatchResult",
    "NightlocError",
    "NightlocWarning",
    "NoiseModel",
    "PreparationParams",
    "Preparer",
    "ReferenceMap",
    "RobotMotion",
    "RouteLocalizer",
    "RouteParams",
    "Traverse",
    "__version__",
    "available_simd_backends",
    "block_normalize",
    "difference_matrix",
    "learn",
    "load_params",
    "load_traverse",
    "localize_night",
    "mapping",
    "match",
    "patch_normalize",
    "prepare",
    "rotational_sad",
    "route",
    "save_params",
    "save_traverse",
    "set_simd_backend",
    "shifts_to_headings",
    "simd_backend",
    "traverse_odometry",
    "use_simd_backend",
]
