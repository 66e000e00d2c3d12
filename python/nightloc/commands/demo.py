"""``nightloc demo``: the method end to end on the embedded default data.

Until the synthetic world and the 2D localizer land, the demo runs the matching core on a small
synthetic reference map: a robot that turned finds its place and heading again.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..matching import match, patch_normalize
from ..simd import simd_backend


def register(subparsers: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    parser = subparsers.add_parser("demo", help="run the method on the embedded default data")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.set_defaults(run=run)


def synthetic_panoramas(n: int, rng: np.random.Generator, height: int = 24, width: int = 48) -> np.ndarray:
    """``n`` smooth random 360-degree panoramas, (n, height, width) uint8."""
    columns = np.arange(width) * 2 * np.pi / width
    rows = np.linspace(0, 1, height)[:, None]
    images = np.empty((n, height, width), dtype=np.uint8)
    for i in range(n):
        field = np.zeros((height, width))
        for harmonic in range(1, 6):
            phase, amplitude, tilt = rng.uniform(0, 2 * np.pi), rng.uniform(10, 40) / harmonic, rng.uniform(-2, 2)
            field += amplitude * np.sin(harmonic * columns[None, :] + phase + tilt * rows)
        images[i] = np.clip(128 + field, 0, 255).astype(np.uint8)
    return images


def run(args: argparse.Namespace) -> int:
    rng = np.random.default_rng(args.seed)
    refs = patch_normalize(synthetic_panoramas(50, rng))
    print(f"reference map: {len(refs)} synthetic 48x24 panoramas (SIMD path {simd_backend()})")
    hits = 0
    start = time.perf_counter()
    for place in range(len(refs)):
        turn = int(rng.integers(0, 48))
        query = np.roll(refs[place], turn, axis=1).astype(np.int16) + rng.normal(0, 12, refs[place].shape)
        query = np.clip(query, 0, 255).astype(np.uint8)
        result = match(query, refs)
        hits += result.index == place and result.shift == turn
    elapsed = time.perf_counter() - start
    print(f"{hits}/{len(refs)} noisy, turned queries matched to the right place and heading")
    print(f"{1e3 * elapsed / len(refs):.3f} ms per query (50 references x 48 shifts)")
    return 0
