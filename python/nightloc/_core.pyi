"""Type stubs of nightloc's compiled core (private: use the functions in ``nightloc``)."""

from typing import List, Tuple

import numpy as np
import numpy.typing as npt

__version__: str
DEFAULT_PATCH_SCALE: float
MAX_IMAGE_PIXELS: int
MAX_PATCH_RADIUS: int
MAX_TRAJECTORY_PLAN_ENTRIES: float

def simd_backend() -> str: ...
def best_simd_backend() -> str: ...
def available_simd_backends() -> List[str]: ...
def set_simd_backend(name: str) -> None: ...
def reset_simd_backend() -> None: ...
def patch_normalize(
    images: npt.NDArray[np.uint8], radius: int, wrap: bool, scale: float
) -> npt.NDArray[np.uint8]: ...
def block_normalize(images: npt.NDArray[np.uint8], side: int) -> npt.NDArray[np.uint8]: ...
def rotational_sad(
    query: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    divisor: float = 0.0,
) -> npt.NDArray[np.float32]: ...
def difference_matrix(
    queries: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    divisor: float = 0.0,
) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]: ...
def match(
    query: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
) -> Tuple[int, npt.NDArray[np.float32], npt.NDArray[np.int32], npt.NDArray[np.float64]]: ...
def difference_matrix_sums(
    queries: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
) -> Tuple[npt.NDArray[np.uint32], npt.NDArray[np.int32]]: ...

# Route mode (cpp/bindings/register_route.cpp; use nightloc.route)
def zscore_bound(radius: int) -> float: ...
def enhance_contrast(
    d: npt.NDArray[np.float32], radius: int, offset: str, threads: int, out: npt.NDArray[np.float32] | None = None
) -> Tuple[npt.NDArray[np.float32], float]: ...
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
) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]: ...
def trajectory_plan(ds: int, vmin: float, vmax: float, uniqueness_radius: int, causal: bool) -> dict: ...
def difference_matrix_into(
    queries: npt.NDArray[np.uint8],
    refs: npt.NDArray[np.uint8],
    shifts: npt.NDArray[np.int32],
    threads: int,
    divisor: float,
    out: npt.NDArray[np.float32],
) -> None: ...
