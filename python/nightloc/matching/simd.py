"""Which SIMD path the compiled kernels use, and a way to force one (tests run every path).

The paths give bit-identical results; only their speed differs. The default is the fastest the
CPU supports, or the one named by the environment variable ``NIGHTLOC_SIMD`` (a name of
:data:`ALL_BACKENDS`) when it is set to a supported path. :data:`SIMD_PATHS` is the core's
registry of the paths: each one's architecture, whether this build has it and this CPU runs it.

On CPUs with AVX-512 VNNI, the ``avx512bw`` path's all-shift kernel can accumulate with
``vpdpwssd`` (``"vnni"``) or ``vpaddw`` (same results); which is faster depends on the CPU
(docs/cpp_core.md has the figures). The choice is made once per process — a table for AMD Zen 4,
otherwise both are timed once at first use (vnni must win by 2 %) — and ``avx512_sad_variant()`` says which and why;
``NIGHTLOC_AVX512_VNNI=0`` or ``1`` forces it.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Iterator
from typing import NamedTuple

from .. import _core

__all__ = [
    "ALL_BACKENDS",
    "SIMD_PATHS",
    "SimdPath",
    "available_simd_backends",
    "avx512_sad_variant",
    "set_simd_backend",
    "simd_backend",
    "use_simd_backend",
]

#: Every path the core knows (named once, in the C++ core), whether or not this CPU has it.
ALL_BACKENDS: tuple[str, ...] = tuple(_core.ALL_SIMD_BACKENDS)


class SimdPath(NamedTuple):
    """One SIMD path of the core's registry (``cpp/src/dispatch/simd_paths.cpp``).

    Attributes:
        name: as :data:`ALL_BACKENDS` and ``NIGHTLOC_SIMD`` name it.
        architecture: ``"any"`` (the scalar reference), ``"x86-64"`` or ``"aarch64"``.
        compiled: whether this build has its kernels; ``supported``: and this CPU runs them.
        alignment: bytes the SAD engine aligns bands of references to (None: not compiled).
        all_shift_kernel: whether it has the all-shift SAD kernel (the interleaved layout).
        float_kernels: the compilation of its float kernels (``"scalar"``, ``"baseline"``,
            ``"avx2"``, ``"avx512"``; None: not compiled).
    """

    name: str
    architecture: str
    compiled: bool
    supported: bool
    alignment: int | None
    all_shift_kernel: bool
    float_kernels: str | None


#: The core's registry of SIMD paths, in :data:`ALL_BACKENDS`' order.
SIMD_PATHS: tuple[SimdPath, ...] = tuple(SimdPath(**row) for row in _core.simd_paths())


def simd_backend() -> str:
    """Name of the SIMD path in use, one of ``ALL_BACKENDS``."""
    return _core.simd_backend()


def available_simd_backends() -> tuple[str, ...]:
    """The SIMD paths this CPU supports, slowest first (``"scalar"`` always)."""
    return tuple(_core.available_simd_backends())


def set_simd_backend(name: str | None) -> None:
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


def avx512_sad_variant() -> tuple[str, str] | None:
    """``(variant, reason)`` of the ``avx512bw`` path's all-shift SAD kernel, e.g.
    ``("vpaddw", "CPU table: AuthenticAMD family 19h ...")``; None on CPUs without AVX-512BW.

    The first call may time both variants (once per process).
    """
    found = _core.avx512_sad_variant()
    return None if found is None else (str(found[0]), str(found[1]))


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
