"""Preparation throughput (frames/s) against the cost of matching one frame against 500 images.

Per frame size, one group holds: a plain numpy reference of the pipeline, the OpenCV
formulation (``cv2.cvtColor``, ``cv2.equalizeHist``, integral-image area sums, the core's patch
normalization: :meth:`Preparer.downsample_opencv`), ``nightloc.prepare`` on BGR and on grey
frames (the compiled core, ``nightloc::prepare_frame``), and, for comparison, the core matching
one prepared query against a 500-image map (48 shifts, 1 thread). A second group per size
compares the area downsample alone: ``cv2.resize(INTER_AREA)``, the OpenCV/numpy integral image
and the core. ``extra_info["frames_per_s"]`` is computed from the minimum time.

    python -m pytest benchmarks/test_bench_preparation.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.preparation.downsample import area_downsample, area_downsample_opencv

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import oracle
from preparation_oracle import area_weights, equalize_oracle, panorama

SIZES = [(480, 640), (320, 640), (960, 1920)]
MAP_SIZE = 500
_cache: dict = {}


def frame(size):
    if size not in _cache:
        base = panorama(size[0], size[1], seed=1)
        noise = np.random.default_rng(2).integers(0, 24, size=base.shape, dtype=np.uint8)
        _cache[size] = np.ascontiguousarray(base // 2 + noise)
    return _cache[size]


def reference_map():
    if "map" not in _cache:
        rng = np.random.default_rng(0)
        refs = nightloc.patch_normalize(rng.integers(0, 256, size=(MAP_SIZE, 24, 48), dtype=np.uint8))
        _cache["map"] = refs
    return _cache["map"]


def numpy_prepare(image: np.ndarray, weights_y: np.ndarray, weights_x: np.ndarray) -> np.ndarray:
    """The default pipeline in plain numpy: BT.601 grey, equalization, exact area means, eq. (1)."""
    grey = np.rint(image.astype(np.float64) @ np.array([0.114, 0.587, 0.299])).astype(np.uint8)
    small = np.rint(weights_y @ equalize_oracle(grey, 256).astype(np.float64) @ weights_x.T).astype(np.uint8)
    return oracle.patch_normalize(small, 4, True, nightloc.DEFAULT_PATCH_SCALE)


def record(benchmark, frames=1):
    stats = getattr(benchmark, "stats", None)
    if stats is not None and stats.stats.min > 0:
        benchmark.extra_info["frames_per_s"] = round(frames / stats.stats.min, 1)
        benchmark.extra_info["ms_per_frame"] = round(1e3 * stats.stats.min / frames, 3)


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[1]}x{s[0]}")
def test_numpy_reference(benchmark, size):
    image = frame(size)
    weights_y, weights_x = area_weights(size[0], 24), area_weights(size[1], 48)
    benchmark.group = f"prepare one {size[1]}x{size[0]} BGR frame vs match against {MAP_SIZE}"
    got = benchmark.pedantic(numpy_prepare, args=(image, weights_y, weights_x), rounds=3)
    record(benchmark)
    fast = nightloc.prepare(image)
    # +-1 grey level before normalization (rounding of grey and area means) moves few outputs
    assert np.abs(got.astype(int) - fast).mean() < 3.0


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[1]}x{s[0]}")
def test_prepare_opencv(benchmark, size):
    image = frame(size)
    preparer = nightloc.Preparer()
    benchmark.group = f"prepare one {size[1]}x{size[0]} BGR frame vs match against {MAP_SIZE}"
    got = benchmark(lambda: preparer.normalize(preparer.downsample_opencv(image)))
    record(benchmark)
    np.testing.assert_array_equal(got, preparer(image))


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[1]}x{s[0]}")
def test_prepare(benchmark, size):
    image = frame(size)
    preparer = nightloc.Preparer()
    benchmark.group = f"prepare one {size[1]}x{size[0]} BGR frame vs match against {MAP_SIZE}"
    got = benchmark(preparer, image)
    record(benchmark)
    assert got.shape == (24, 48) and got.dtype == np.uint8


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[1]}x{s[0]}")
def test_prepare_grey(benchmark, size):
    grey = cv2.cvtColor(frame(size), cv2.COLOR_BGR2GRAY)
    preparer = nightloc.Preparer()
    benchmark.group = f"prepare one {size[1]}x{size[0]} BGR frame vs match against {MAP_SIZE}"
    got = benchmark(preparer, grey)
    record(benchmark)
    np.testing.assert_array_equal(got, preparer.normalize(preparer.downsample_opencv(grey)))


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[1]}x{s[0]}")
def test_match_one_frame(benchmark, size):
    refs = reference_map()
    query = np.roll(refs[123], 5, axis=1)
    benchmark.group = f"prepare one {size[1]}x{size[0]} BGR frame vs match against {MAP_SIZE}"
    result = benchmark(nightloc.match, query, refs, threads=1)
    record(benchmark)
    assert result.index == 123 and result.shift == 5


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[1]}x{s[0]}")
@pytest.mark.parametrize("method", ["cv2.resize", "integral image (numpy)", "nightloc"])
def test_area_downsample(benchmark, size, method):
    grey = cv2.cvtColor(frame(size), cv2.COLOR_BGR2GRAY)
    benchmark.group = f"area downsample {size[1]}x{size[0]} grey to 48x24"
    if method == "cv2.resize":
        got = benchmark(cv2.resize, grey, (48, 24), interpolation=cv2.INTER_AREA)
    elif method == "nightloc":
        got = benchmark(area_downsample, grey, 48, 24)
        np.testing.assert_array_equal(got, area_downsample_opencv(grey, 48, 24))
    else:
        got = benchmark(area_downsample_opencv, grey, 48, 24)
    record(benchmark)
    exact = area_weights(size[0], 24) @ grey.astype(np.float64) @ area_weights(size[1], 48).T
    assert np.abs(got - exact).max() < 0.52


def test_prepare_stack_from_traverse(benchmark, tmp_path):
    """Reading (PNG decode) and preparing a 32-frame 640x480 traverse: the end-to-end rate."""
    base = frame((480, 640))
    traverse = nightloc.save_traverse(tmp_path / "t", (np.roll(base, 7 * i, axis=1) for i in range(32)))
    benchmark.group = "read + prepare a traverse of 32 PNG frames, 640x480"
    got = benchmark.pedantic(nightloc.prepare, args=(traverse,), rounds=3)
    record(benchmark, frames=32)
    assert got.shape == (32, 24, 48)
