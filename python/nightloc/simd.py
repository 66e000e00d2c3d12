"""Which SIMD path the compiled kernels use, and a way to force one (tests run every path).

The paths give bit-identical results; only their speed differs. The default is the fastest the
CPU supports, or the one named by the environment variable ``NIGHTLOC_SIMD`` (one of
``ALL_BACKENDS``: ``scalar``, ``sse2``, ``avx2``, ``avx512bw``) when it is set to a supported path.

On CPUs with AVX-512 VNNI, the ``avx512bw`` path's all-shift kernel accumulates with
``vpdpwssd`` instead of ``vpaddw`` (same results, about 15 % faster); the environment variable
``NIGHTLOC_AVX512_VNNI=0``, read once at start-up, keeps the ``vpaddw`` kernel.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from typing import Iterator, Optional, Tuple

from . import _core

__all__ = ["ALL_BACKENDS", "simd_backend", "available_simd_backends", "set_simd_backend", "use_simd_backend"]

#: Every path the core knows (named once, in the C++ core), whether or not this CPU has it.
ALL_BACKENDS: Tuple[str, ...] = tuple(_core.ALL_SIMD_BACKENDS)


def simd_backend() -> str:
    """Name of the SIMD path in use, one of ``ALL_BACKENDS``."""
    return _core.simd_backend()


def available_simd_backends() -> Tuple[str, ...]:
    """The SIMD paths this CPU supports, slowest first (``"scalar"`` always)."""
    return tuple(_core.available_simd_backends())


def set_simd_backend(name: Optional[str]) -> None:
    """Forces the SIMD path for the whole process; ``None`` returns to the default.

    Raises ValueError for an unknown name or a path this CPU does not support.
    """
    if name is None:
        _core.reset_simd_backend()
    else:
        _core.set_simd_backend(str(name))


@contextlib.contextmanager
def use_simd_backend(name: str) -> Iterator[None]:
    """Context manager: run the block on SIMD path ``name``, then restore the previous path.

    The setting is process-wide: do not use it while other threads call nightloc.
    """
    previous = simd_backend()
    set_simd_backend(name)
    try:
        yield
    finally:
        _core.set_simd_backend(previous)


def _check_environment() -> None:
    requested = os.environ.get("NIGHTLOC_SIMD")
    if requested and requested not in available_simd_backends():
        reason = "unknown" if requested not in ALL_BACKENDS else "not supported by this CPU"
        warnings.warn(
            f"NIGHTLOC_SIMD={requested!r} is {reason}; using {simd_backend()!r} "
            f"(supported: {', '.join(available_simd_backends())})",
            RuntimeWarning,
            stacklevel=3,
        )


_check_environment()
