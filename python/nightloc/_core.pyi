"""Type stubs of nightloc's compiled core (private: use the functions in ``nightloc``)."""

from typing import List, Tuple

import numpy as np
import numpy.typing as npt

__version__: str
DEFAULT_PATCH_SCALE: float
MAX_IMAGE_PIXELS: int

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
