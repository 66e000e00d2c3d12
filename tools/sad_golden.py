"""Records the outputs of the matching core on fixed inputs (tests/matching/data/sad_golden.npz).

The file was written by the core as it was before the translation window (main at 2949b59): the
window-0 outputs of every later core must equal it bit for bit
(tests/matching/test_shift_window.py). Rerun only to extend the cases, with a core whose
window-0 outputs are known to be unchanged::

    python tools/sad_golden.py tests/matching/data/sad_golden.npz
"""

from __future__ import annotations

import sys

import numpy as np

from nightloc import _core

# name, (height, width), queries, references, shift list (None: all), value range, divisor
CASES = [
    ("pano", (24, 48), 6, 40, None, 256, 0.0),
    ("flat", (24, 48), 4, 30, None, 3, 0.0),
    ("forward", (32, 64), 7, 50, [0], 256, 0.0),
    ("subset", (17, 40), 3, 25, [5, 3, 30], 256, 0.0),
    ("tiny", (3, 7), 3, 9, None, 256, 0.0),
    ("divisor", (24, 48), 5, 33, [0], 256, 37.0),
    ("odd", (13, 52), 4, 19, None, 4, 0.0),
]


def hashed_bytes(seed: int, shape: tuple[int, ...], high: int) -> np.ndarray:
    """Deterministic pseudo-random bytes in [0, high) (a multiplicative hash of the index, so the
    inputs need not be stored and do not depend on numpy's generators)."""
    index = np.arange(int(np.prod(shape)), dtype=np.uint64) + np.uint64(seed) * np.uint64(1_000_003)
    mixed = (index * np.uint64(2654435761) + np.uint64(0x9E3779B9)) & np.uint64(0xFFFFFFFF)
    mixed = (mixed ^ (mixed >> np.uint64(15))) * np.uint64(2246822519) & np.uint64(0xFFFFFFFF)
    return ((mixed >> np.uint64(13)) % np.uint64(high)).astype(np.uint8).reshape(shape)


def case_inputs(case_index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(queries, refs, shifts, divisor) of CASES[case_index]."""
    _name, (h, w), n_q, n_r, shifts, high, divisor = CASES[case_index]
    queries = hashed_bytes(2 * case_index, (n_q, h, w), high)
    refs = hashed_bytes(2 * case_index + 1, (n_r, h, w), high)
    refs[-1] = refs[1]  # a duplicate reference: a tie between references
    shift_array = np.arange(w, dtype=np.int32) if shifts is None else np.asarray(shifts, np.int32)
    return queries, refs, shift_array, divisor


def record() -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for case_index, case in enumerate(CASES):
        name = case[0]
        queries, refs, shift_array, divisor = case_inputs(case_index)
        scores, best = _core.difference_matrix(queries, refs, shift_array, 1, divisor)
        table = _core.rotational_sad(queries[0], refs, shift_array, 1, divisor)
        index, m_scores, m_shifts, headings = _core.match(queries[0], refs, shift_array, 1)
        out |= {
            f"{name}/scores": scores,
            f"{name}/best_shifts": best,
            f"{name}/table": table,
            f"{name}/match_index": np.int64(index),
            f"{name}/match_scores": m_scores,
            f"{name}/match_shifts": m_shifts,
            f"{name}/match_headings": headings,
        }
    return out


if __name__ == "__main__":
    np.savez_compressed(sys.argv[1], **record())
