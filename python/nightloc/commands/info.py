"""``nightloc info``: version, SIMD paths and the kernel's speed on this machine."""

from __future__ import annotations

import argparse
import time

import numpy as np

from .. import _core
from .._core import __version__
from ..matching.sad import match
from ..matching.simd import available_simd_backends, simd_backend, use_simd_backend

#: Most references in the speed test (1152 bytes each: 115 MB).
MAX_SPEED_TEST_REFS = 100_000


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "info",
        help="version, SIMD paths and matching speed on this machine",
        description="Prints nightloc's version, the SIMD paths this CPU supports (and the one in use) and the "
        "speed of the rotation-invariant match on each: one 48x24 query against --refs references at all 48 "
        "shifts, on one thread, in byte comparisons per second.",
    )
    parser.add_argument("--refs", type=int, default=5000, help="references in the speed test (default 5000)")
    parser.set_defaults(run=run)


def kernel_speed(n_refs: int, threads: int = 1, repeats: int = 5) -> float:
    """Best-of-``repeats`` byte comparisons per second of one 48x24 query against ``n_refs``."""
    rng = np.random.default_rng(0)
    refs = rng.integers(0, 256, size=(n_refs, 24, 48), dtype=np.uint8)
    query = refs[n_refs // 2].copy()
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        match(query, refs, threads=threads)
        best = min(best, time.perf_counter() - start)
    return n_refs * 24 * 48 * 48 / best


def run(args: argparse.Namespace) -> int:
    if not 1 <= args.refs <= MAX_SPEED_TEST_REFS:
        raise ValueError(
            f"--refs must be in 1..{MAX_SPEED_TEST_REFS} (MAX_SPEED_TEST_REFS: 1152 bytes each), got {args.refs}"
        )
    print(f"nightloc {__version__}")
    print(f"SIMD path in use: {simd_backend()}  (supported: {', '.join(available_simd_backends())})")
    variant = _core.avx512_sad_variant()
    if variant is not None:
        print(f"avx512bw all-shift kernel: {variant[0]}  ({variant[1]})")
    print(f"rotation-invariant SAD, 48x24 images, 48 shifts, {args.refs} references, 1 thread:")
    for backend in available_simd_backends():
        variants = _core.available_avx512_sad_variants() if backend == "avx512bw" else [None]
        for name in variants:
            _core.set_avx512_sad_variant(name)
            try:
                with use_simd_backend(backend):
                    speed = kernel_speed(args.refs, repeats=1 if backend == "scalar" else 5)
            finally:
                _core.set_avx512_sad_variant(None)
            label = backend if name is None else f"{backend} {name}"
            print(f"  {label:16s} {speed / 1e9:8.1f} G byte comparisons/s")
    if variant is not None and len(_core.available_avx512_sad_variants()) > 1:
        print(
            f"(the avx512bw variant in use was chosen as above, not from this table of {args.refs} references: where "
            f"the two are close, which is faster changes with the number of references and the machine's load)"
        )
    return 0
