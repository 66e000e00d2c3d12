"""Type stubs of nightloc's compiled core (private: use the functions in ``nightloc``)."""

from typing import Any, Literal

import numpy as np
import numpy.typing as npt

__version__: str
DEFAULT_PATCH_SCALE: float
WHEEL_ODOMETRY_NOISE: tuple[float, float, float, float]
MAP_FORMAT_VERSION: int
DAY_MAP_FORMAT_VERSION: int
MAX_IMAGE_PIXELS: int
MAX_PATCH_RADIUS: int
MAX_TRAJECTORY_PLAN_ENTRIES: float
ALL_SIMD_BACKENDS: tuple[str, ...]

# The settings schema (cpp/bindings/settings_glue.hpp, nightloc/settings.hpp; use nightloc.schema).
# Each settings class below has one attribute per row of its table, in the table's order
# (tests/test_settings_schema.py checks these lines against the tables).
class SettingError(ValueError):
    setting: str
    requirement: str

_SettingsRow = dict[str, Any]

def simd_paths() -> list[dict[str, Any]]: ...
def simd_backend() -> str: ...
def best_simd_backend() -> str: ...
def available_simd_backends() -> list[str]: ...
def set_simd_backend(name: str) -> None: ...
def reset_simd_backend() -> None: ...
def available_avx512_sad_variants() -> list[str]: ...
def avx512_sad_variant() -> tuple[str, str] | None: ...
def set_avx512_sad_variant(name: str | None) -> None: ...
def patch_normalize(images: npt.NDArray[np.uint8], radius: int, wrap: bool, scale: float) -> npt.NDArray[np.uint8]: ...
def block_normalize(images: npt.NDArray[np.uint8], side: int) -> npt.NDArray[np.uint8]: ...
def rotational_sad(
    query: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    divisor: float = 0.0,
    window: tuple[int, int] = (0, 0),
) -> npt.NDArray[np.float32]: ...
def shift_table(
    query: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    divisor: float = 0.0,
    window: tuple[int, int] = (0, 0),
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]: ...
def difference_matrix(
    queries: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    divisor: float = 0.0,
    window: tuple[int, int] = (0, 0),
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32], npt.NDArray[np.int32]]: ...
def match(
    query: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    window: tuple[int, int] = (0, 0),
) -> tuple[int, npt.NDArray[np.float32], npt.NDArray[np.int32], npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...
def difference_matrix_sums(
    queries: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
) -> tuple[npt.NDArray[np.uint32], npt.NDArray[np.int32]]: ...

# Route mode (cpp/bindings/register_route.cpp; use nightloc.route)
def zscore_bound(radius: int) -> float: ...
def enhance_contrast(
    d: npt.NDArray[np.float32], radius: int, offset: str, threads: int, out: npt.NDArray[np.float32] | None = None
) -> tuple[npt.NDArray[np.float32], float]: ...
def trajectory_search(
    dd: npt.NDArray[np.float32],
    ds: int,
    vmin: float,
    vmax: float,
    uniqueness_radius: int,
    causal: bool,
    query_begin: int,
    query_end: int,
    threads: int,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]: ...
def trajectory_plan(ds: int, vmin: float, vmax: float, uniqueness_radius: int, causal: bool) -> dict: ...
def difference_matrix_into(
    queries: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    divisor: float,
    out: npt.NDArray[np.float32],
    window: tuple[int, int] = (0, 0),
) -> None: ...

# Route filter (cpp/bindings/register_route.cpp, nightloc/route_filter.hpp; use nightloc.route.filter)
class RouteFilterParams:
    vmin: float
    vmax: float
    backward: float
    floor: float
    sharpness: float
    clip: float
    leave: float
    rejoin: float
    window: int
    motion: str
    speed_min: float
    speed_max: float
    speed_step: float
    speed_jitter: float
    speed_change: float
    speed_tau: float
    speed_cells: int
    odometry_noise: float
    odometry_jitter: float
    odometry_novelty: float
    odometry_cells: int
    def __init__(self) -> None: ...
    def validate(self) -> None: ...
    def to_dict(self) -> dict[str, Any]: ...
    @staticmethod
    def fields() -> list[_SettingsRow]: ...

class TrajectoryParams:
    ds: int
    vmin: float
    vmax: float
    uniqueness_radius: int
    mode: Literal["centred", "causal"]
    def __init__(self) -> None: ...
    def validate(self) -> None: ...
    def to_dict(self) -> dict[str, Any]: ...
    @staticmethod
    def fields() -> list[_SettingsRow]: ...

_FilterRun = tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]

class RouteFilter:
    def __init__(
        self, n_refs: int, params: RouteFilterParams, reference_distances: npt.NDArray[np.float64] | None = None
    ) -> None: ...
    def step(
        self, row: npt.NDArray[np.float32], weight: float = 1.0, advance: float = 0.0
    ) -> tuple[int, float, float, float]: ...
    def run(
        self,
        matrix: npt.NDArray[np.float32],
        weights: npt.NDArray[np.float64] | None = None,
        threads: int = 1,
        advances: npt.NDArray[np.float64] | None = None,
    ) -> _FilterRun: ...
    def frame(
        self,
        image: npt.NDArray[np.uint8],
        refs: npt.NDArray[np.uint8],
        shifts: npt.NDArray[np.int32],
        divisor: float,
        enhance_radius: int,
        min_texture: float,
        threads: int,
        row: npt.NDArray[np.float32],
        window: tuple[int, int] = (0, 0),
        advance: float = 0.0,
    ) -> tuple[int, float, float, float, float]: ...
    def reset(self) -> None: ...
    def __copy__(self) -> RouteFilter: ...
    def __deepcopy__(self, memo: dict) -> RouteFilter: ...
    def set_state(self, belief: npt.NDArray[np.float64], off_route: float) -> None: ...
    @property
    def belief(self) -> npt.NDArray[np.float64]: ...
    @property
    def off_route(self) -> float: ...
    @property
    def n_refs(self) -> int: ...
    @property
    def motion(self) -> str: ...
    @property
    def plane_belief(self) -> npt.NDArray[np.float64]: ...

def route_filter(
    matrix: npt.NDArray[np.float32],
    params: RouteFilterParams,
    weights: npt.NDArray[np.float64] | None = None,
    threads: int = 1,
    advances: npt.NDArray[np.float64] | None = None,
    reference_distances: npt.NDArray[np.float64] | None = None,
) -> _FilterRun: ...
def speed_chain(
    params: RouteFilterParams,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], int]: ...
def odometry_spread(advance: float, spacing: float, params: RouteFilterParams) -> npt.NDArray[np.float64]: ...
def motion_kernel(vmin: float, vmax: float, backward: float) -> tuple[int, npt.NDArray[np.float64]]: ...
def route_motion_names() -> list[str]: ...
def route_motion_speeds(params: RouteFilterParams) -> tuple[float, float, list[str]]: ...
def route_motion_models() -> list[dict[str, Any]]: ...
def texture_weights(images: npt.NDArray[np.uint8], min_texture: float) -> npt.NDArray[np.float64]: ...

# Frame preparation (cpp/bindings/register_preparation.cpp; use nightloc.prepare)
class PrepareSettings:
    """What prepare_frame does, with the core's defaults (nightloc/prepare.hpp); validate() checks
    ranges."""

    crop_top: int
    crop_bottom: int
    crop_left: int
    crop_right: int
    equalize: Literal["none", "global", "clahe"]
    width: int
    height: int
    patch_normalize: bool
    radius: int
    wrap: bool
    scale: float
    def __init__(self) -> None: ...
    def validate(self) -> None: ...
    def to_dict(self) -> dict[str, Any]: ...
    @staticmethod
    def fields() -> list[_SettingsRow]: ...

def prepare_frame(frame: npt.NDArray[np.uint8], order: str, settings: PrepareSettings) -> npt.NDArray[np.uint8]: ...
def downsample_method(in_height: int, in_width: int, out_height: int, out_width: int) -> str: ...

# Heat maps and the grid filter (cpp/bindings/register_localization.cpp; use
# nightloc.localization.sequence, nightloc.Localizer and nightloc.localization.grid_filter)
def add_translated(
    out: npt.NDArray[np.floating],
    source: npt.NDArray[np.floating],
    height: int,
    width: int,
    stride: int,
    shift_x: float,
    shift_y: float,
) -> None: ...

class HeatWeights:
    def __init__(
        self,
        height: int,
        width: int,
        n_places: int,
        indptr: npt.NDArray[np.int32],
        indices: npt.NDArray[np.int32],
        data: npt.NDArray[np.float32],
    ) -> None: ...
    @property
    def height(self) -> int: ...
    @property
    def width(self) -> int: ...
    @property
    def places(self) -> int: ...
    def interpolate(self, values: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]: ...

# (x, y, heading, cov_xx, cov_xy, cov_yy, credible_radius, confidence, cell, flat, heading_var)
_GridEstimate = tuple[float, float, float, float, float, float, float, float, int, bool, float]

class GridFilterSettings:
    """The grid filter's settings with the core's defaults (nightloc/grid_filter.hpp); setting a
    value checks its type (finite; counts non-negative integers), validate() its range."""

    heading_bins: int
    likelihood_gain: float
    distance_std: float
    heading_std: float
    distance_per_metre: float
    heading_per_radian: float
    position_floor: float
    heading_floor: float
    uniform_floor: float
    unknown_spread: float
    credibility: float
    confidence_radius: float
    estimate_window: int
    negligible: float
    settle_frames: int
    score_cap: float
    lookalike_places: float
    def __init__(self) -> None: ...
    def validate(self) -> None: ...
    def to_dict(self) -> dict[str, Any]: ...
    @staticmethod
    def fields() -> list[_SettingsRow]: ...

class GridFilter:
    """The grid Bayes filter (nightloc/grid_filter.hpp). Motion kinds: 0 none, 1 unknown,
    2 map frame (a=dx, b=dy), 3 robot frame (a=forward, b=left, c=turn)."""

    def __init__(
        self,
        weights: HeatWeights,
        x0: float,
        y0: float,
        dx: float,
        dy: float,
        place_of_ref: npt.NDArray[np.int32],
        ref_headings: npt.NDArray[np.float64] | None,
        columns: int,
        shifts: npt.NDArray[np.int32],
        settings: GridFilterSettings,
        field_of_view: float = 0.0,
        window_columns: int = 0,
        window_rows: int = 0,
    ) -> None: ...
    def reset(self) -> None: ...
    def __copy__(self) -> GridFilter: ...
    def set_learned(self, learned: npt.NDArray[np.uint8]) -> None: ...
    def set_noise(
        self, distance_std: float, heading_std: float, distance_per_metre: float = 0.0, heading_per_radian: float = 0.0
    ) -> None: ...
    def predict(self, kind: int, a: float, b: float, c: float) -> None: ...
    def step_image(
        self,
        query: npt.NDArray[np.uint8],
        refs: npt.NDArray[np.uint8],
        kind: int,
        a: float,
        b: float,
        c: float,
        threads: int,
    ) -> tuple[_GridEstimate, npt.NDArray[np.float32], npt.NDArray[np.int32]]: ...
    def step_table(
        self, table: npt.NDArray[np.float32], kind: int, a: float, b: float, c: float
    ) -> tuple[_GridEstimate, npt.NDArray[np.float32], npt.NDArray[np.int32]]: ...
    def step_table_with_prior(
        self, table: npt.NDArray[np.float32], kind: int, a: float, b: float, c: float
    ) -> tuple[tuple[_GridEstimate, npt.NDArray[np.float32], npt.NDArray[np.int32]], npt.NDArray[np.float64]]: ...
    def estimate(self) -> _GridEstimate: ...
    def marginal(self) -> npt.NDArray[np.float64]: ...
    def belief(self) -> npt.NDArray[np.float64]: ...
    def set_belief(self, belief: npt.NDArray[np.float32], pose: bool, offset: float) -> None: ...
    def table(self) -> npt.NDArray[np.float32]: ...
    @property
    def pose_mode(self) -> bool: ...
    @property
    def can_pose(self) -> bool: ...
    @property
    def heading_bins(self) -> int: ...
    @property
    def settings(self) -> GridFilterSettings: ...
    @property
    def offset(self) -> float: ...
    @property
    def lambda_(self) -> float: ...
    @property
    def frames(self) -> int: ...
    @property
    def score_cap(self) -> float: ...
    @property
    def forward(self) -> bool: ...
    @property
    def sparse_blocks(self) -> int: ...
    @property
    def memory_bytes(self) -> int: ...

class HeatSequence:
    def __init__(
        self,
        weights: HeatWeights,
        capacity: int,
        exclusion_rows: int,
        exclusion_cols: int,
        exclusion_mask: npt.NDArray[np.uint8],
    ) -> None: ...
    def push(self, place_values: npt.NDArray[np.float32], fill: float) -> None: ...
    def fuse_peak(self, offsets: npt.NDArray[np.float64]) -> tuple[float, int, float, float, float | None]: ...
    def fused(self) -> npt.NDArray[np.float32]: ...
    def frame(self, k: int) -> npt.NDArray[np.float32]: ...
    def fill(self, k: int) -> float: ...
    def clear(self) -> None: ...
    @property
    def size(self) -> int: ...
    @property
    def capacity(self) -> int: ...

# The teach run (cpp/bindings/register_mapping.cpp; use nightloc.mapping.warping)
def warp_costs(
    images: npt.NDArray[np.uint8],
    stacks: npt.NDArray[np.uint8],
    row_begin: npt.NDArray[np.int32],
    row_end: npt.NDArray[np.int32],
    level: npt.NDArray[np.int32],
    sign: npt.NDArray[np.int32],
    pairs: npt.NDArray[np.int32],
    first_direction: npt.NDArray[np.int32],
    n_directions: int,
    first_shift: npt.NDArray[np.int32],
    n_shifts: int,
    threads: int = 1,
) -> npt.NDArray[np.float64]: ...
