"""Bad input to the matching API: a TypeError/ValueError that says what was expected, never a crash."""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc import _core

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize

IMG = np.zeros((24, 48), np.uint8)
STACK = np.zeros((5, 24, 48), np.uint8)

CASES = [
    # (call, exception type, words the message must contain)
    (lambda: nightloc.match(IMG.astype(np.float64), STACK), TypeError, "uint8"),
    (lambda: nightloc.match(IMG, STACK.astype(np.int16)), TypeError, "uint8"),
    (lambda: nightloc.match(IMG.tolist(), STACK), TypeError, "ndarray"),
    (lambda: nightloc.match(STACK, STACK), ValueError, "2-D"),
    (lambda: nightloc.match(IMG, IMG), ValueError, "newaxis"),
    (lambda: nightloc.match(IMG, STACK[:0]), ValueError, "empty"),
    (lambda: nightloc.match(np.zeros((24, 40), np.uint8), STACK), ValueError, "24x40"),
    (lambda: nightloc.match(IMG[:, ::2], STACK[:, :, ::2]), ValueError, "contiguous"),
    (lambda: nightloc.match(IMG, STACK, shifts=[48]), ValueError, "[0, 48)"),
    (lambda: nightloc.match(IMG, STACK, shifts=[-1]), ValueError, "[0, 48)"),
    (lambda: nightloc.match(IMG, STACK, shifts=[3, 3]), ValueError, "repeat"),
    (lambda: nightloc.match(IMG, STACK, shifts=[]), ValueError, "non-empty"),
    (lambda: nightloc.match(IMG, STACK, shifts=[0.5]), TypeError, "integers"),
    (lambda: nightloc.match(IMG, STACK, threads=0), ValueError, "threads"),
    (lambda: nightloc.match(IMG, STACK, threads=1.5), TypeError, "threads"),
    (lambda: nightloc.rotational_sad(IMG, np.zeros((5, 24, 47), np.uint8)), ValueError, "24x47"),
    (lambda: nightloc.difference_matrix(IMG, STACK), ValueError, "3-D"),
    (lambda: nightloc.difference_matrix(STACK[:0], STACK), ValueError, "empty"),
    (lambda: nightloc.difference_matrix(STACK, np.zeros((3, 0, 48), np.uint8)), ValueError, "empty"),
    (lambda: nightloc.difference_matrix(STACK.astype(bool), STACK), TypeError, "uint8"),
    (lambda: nightloc.patch_normalize(IMG.astype(np.float32)), TypeError, "uint8"),
    (lambda: nightloc.patch_normalize(np.zeros((2, 2, 2, 2), np.uint8)), ValueError, "3-D"),
    (lambda: nightloc.patch_normalize(IMG, radius=-1), ValueError, "radius"),
    (lambda: nightloc.patch_normalize(IMG, scale=float("nan")), ValueError, "scale"),
    (lambda: nightloc.patch_normalize(IMG, scale=0), ValueError, "scale"),
    (lambda: nightloc.block_normalize(IMG, side=1), ValueError, "side"),
    (lambda: nightloc.set_simd_backend("altivec"), ValueError, "unknown"),
    # The private core checks its inputs too.
    (lambda: _core.difference_matrix(STACK, STACK, np.arange(48, dtype=np.int64), 1), TypeError, "int32"),
    (lambda: _core.difference_matrix(STACK, STACK, np.array([48], np.int32), 1), ValueError, "outside"),
    (lambda: _core.difference_matrix(STACK[:, :, ::2], STACK, np.array([0], np.int32), 1), ValueError, "contiguous"),
    (lambda: _core.rotational_sad(IMG.astype(np.float32), STACK, np.array([0], np.int32), 1), TypeError, "uint8"),
    (lambda: _core.difference_matrix(STACK, STACK, np.array([0], np.int32), 1, -1.0), ValueError, "divisor"),
    (lambda: _core.patch_normalize(STACK, 4, True, -3.0), ValueError, "scale"),
]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_bad_input_raises_clear_error(case):
    call, error, words = CASES[case]
    with pytest.raises(error) as info:
        call()
    assert words.lower() in str(info.value).lower()


def test_huge_images_are_refused_not_crashing():
    tall = np.zeros((1, 1 << 13, 1 << 12), np.uint8)  # 2^25 pixels > the 2^24 limit
    with pytest.raises(ValueError, match="too large"):
        nightloc.difference_matrix(tall, tall)


def test_read_only_inputs_are_accepted():
    refs = np.random.default_rng(0).integers(0, 256, (4, 24, 48), dtype=np.uint8)
    refs.setflags(write=False)
    assert nightloc.match(refs[1], refs).index == 1
    assert nightloc.patch_normalize(refs).flags.writeable


def test_unsupported_simd_path_is_refused():
    missing = [b for b in _core.ALL_SIMD_BACKENDS if b not in nightloc.available_simd_backends()]
    if not missing:
        pytest.skip("this CPU supports every SIMD path")
    with pytest.raises(ValueError, match="not supported"):
        nightloc.set_simd_backend(missing[0])


def test_pickled_arrays_are_accepted():
    """Arrays rebuilt by pickle (as on Dask or multiprocessing workers) have an equal, not identical, dtype."""
    import pickle

    refs = np.random.default_rng(1).integers(0, 256, (6, 24, 48), dtype=np.uint8)
    again = pickle.loads(pickle.dumps(refs))
    shifts = pickle.loads(pickle.dumps(np.arange(48, dtype=np.int32)))
    scores, best, _rows = _core.difference_matrix(again, again, shifts, 1)
    assert np.all(np.diag(scores) == 0) and np.all(np.diag(best) == 0)
    assert nightloc.match(again[2], again).index == 2
