"""The compiled core's frame preparation against the OpenCV formulation, byte for byte.

The oracle is :meth:`Preparer.downsample_opencv` (``cv2.cvtColor``, ``cv2.equalizeHist``,
``cv2.resize(INTER_AREA)`` / the integral-image means) followed by the core's patch
normalization: the pipeline nightloc used before the core prepared frames. Every test runs on
every SIMD path the CPU has.
"""

from __future__ import annotations

import threading

import cv2
import numpy as np
import pytest

import nightloc
from nightloc import PreparationParams, Preparer, _core
from nightloc.preparation.downsample import area_downsample, area_downsample_opencv

from preparation_oracle import panorama

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize


def _opencv_prepare(frame: np.ndarray, params: PreparationParams) -> np.ndarray:
    preparer = Preparer(params)
    return preparer.normalize(preparer.downsample_opencv(frame))


def _frame(rng: np.random.Generator, h: int, w: int, channels: int, kind: int) -> np.ndarray:
    shape = (h, w) if channels == 2 else (h, w, channels)
    if kind == 0:
        return rng.integers(0, 256, shape, dtype=np.uint8)
    if kind == 1:  # few levels: ties everywhere in the histogram and the means
        return (rng.integers(0, 6, shape) * 51).astype(np.uint8)
    if kind == 2:  # a narrow range, the darkest level rare
        frame = rng.integers(100, 116, shape, dtype=np.uint8)
        frame.reshape(-1)[rng.integers(frame.size)] = 3
        return frame
    base = panorama(h, w, seed=int(rng.integers(1000)))  # smooth, like a camera frame
    if channels == 2:
        return np.ascontiguousarray(base[:, :, 1])
    if channels == 4:
        return np.dstack([base, np.full((h, w), 200, np.uint8)])
    return base


SIZES = [
    (480, 640),
    (320, 640),
    (960, 1920),
    (540, 960),
    (333, 1001),
    (257, 515),
    (100, 97),
    (30, 50),
    (24, 48),
    (48, 96),
    (25, 49),
]


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[1]}x{s[0]}")
def test_core_equals_opencv_on_common_sizes(size, simd_path):
    rng = np.random.default_rng(size[0] * 7 + size[1])
    layouts = [(2, "bgr"), (3, "bgr"), (3, "rgb"), (4, "bgr"), (4, "rgb")]
    if size[0] * size[1] > 500_000:  # large frames: grey and BGR (the kernels are the same per row)
        layouts = layouts[:2]
    for channels, order in layouts:
        for equalize in ("global", "none"):
            frame = _frame(rng, size[0], size[1], channels, kind=int(rng.integers(4)))
            params = PreparationParams(equalize=equalize, channel_order=order)
            np.testing.assert_array_equal(Preparer(params).prepare(frame), _opencv_prepare(frame, params))


def test_core_equals_opencv_on_random_layouts(simd_path):
    """Random frame and output sizes (every downsample method), crops, orders, radii."""
    rng = np.random.default_rng(20)
    methods = set()
    for trial in range(150):
        out_w, out_h = int(rng.integers(1, 70)), int(rng.integers(1, 40))
        if trial % 3 == 0:  # integer factors
            h, w = out_h * int(rng.integers(1, 25)), out_w * int(rng.integers(1, 25))
        else:
            h, w = int(rng.integers(out_h, 700)), int(rng.integers(out_w, 900))
        crop = tuple(int(rng.integers(0, 5)) if rng.random() < 0.3 else 0 for _ in range(4))
        h, w = h + crop[0] + crop[1], w + crop[2] + crop[3]
        channels = int(rng.choice([2, 3, 4]))
        params = PreparationParams(
            width=out_w,
            height=out_h,
            crop=crop,
            equalize=("global", "none")[trial % 2],
            channel_order=("bgr", "rgb")[int(rng.integers(2))],
            radius=int(rng.integers(0, 5)),
            wrap=bool(rng.random() < 0.7),
            patch_normalize=bool(rng.random() < 0.7),
        )
        methods.add(_core.downsample_method(h - crop[0] - crop[1], w - crop[2] - crop[3], out_h, out_w))
        frame = _frame(rng, h, w, channels, kind=trial % 4)
        got = Preparer(params).prepare(frame)
        expected = _opencv_prepare(frame, params)
        np.testing.assert_array_equal(got, expected, err_msg=f"trial {trial}: {frame.shape} {params}")
    assert methods >= {"integral", "blocks", "weights"}


def test_fractional_crops_views_and_single_channel_axis():
    rng = np.random.default_rng(21)
    frame = _frame(rng, 500, 700, 3, kind=3)
    params = PreparationParams(crop=(0.05, 0.1, 0.02, 0.13))
    expected = _opencv_prepare(frame, params)
    np.testing.assert_array_equal(Preparer(params).prepare(frame), expected)
    # non-contiguous views are copied into the core's layout
    wide = np.zeros((500, 1400, 3), np.uint8)
    wide[:, ::2] = frame
    np.testing.assert_array_equal(Preparer(params).prepare(wide[:, ::2]), expected)
    flipped = np.ascontiguousarray(frame[::-1])[::-1]  # negative row stride
    np.testing.assert_array_equal(Preparer(params).prepare(flipped), expected)
    channels_first = np.ascontiguousarray(np.moveaxis(frame, 2, 0))
    np.testing.assert_array_equal(Preparer(params).prepare(np.moveaxis(channels_first, 0, 2)), expected)
    grey = np.ascontiguousarray(frame[:, :, 1])
    np.testing.assert_array_equal(Preparer(params).prepare(grey[:, :, np.newaxis]), _opencv_prepare(grey, params))
    # a row-padded frame (a view into a wider buffer) is used in place
    padded = np.zeros((500, 710, 3), np.uint8)
    padded[:, :700] = frame
    np.testing.assert_array_equal(Preparer(params).prepare(padded[:, :700]), expected)


def test_stacks_and_downsample_use_the_core_with_the_same_bytes():
    rng = np.random.default_rng(22)
    frames = [_frame(rng, 240, 320, 3, kind=k % 4) for k in range(6)]
    params = PreparationParams()
    preparer = Preparer(params)
    expected = np.stack([_opencv_prepare(f, params) for f in frames])
    np.testing.assert_array_equal(preparer.prepare(np.stack(frames)), expected)
    np.testing.assert_array_equal(preparer.prepare(iter(frames)), expected)
    for f in frames:
        np.testing.assert_array_equal(preparer.downsample(f), preparer.downsample_opencv(f))


def test_opencv_keeps_clahe_sixteen_bit_and_upsampling():
    rng = np.random.default_rng(23)
    frame = _frame(rng, 240, 480, 3, kind=3)
    clahe = PreparationParams(equalize="clahe")
    np.testing.assert_array_equal(Preparer(clahe).prepare(frame), _opencv_prepare(frame, clahe))
    deep = (frame[:, :, 1].astype(np.uint16) * 257) + rng.integers(0, 200, frame.shape[:2]).astype(np.uint16)
    prepared = Preparer().prepare(deep)
    np.testing.assert_array_equal(prepared, _opencv_prepare(deep, PreparationParams()))
    assert prepared.shape == (24, 48)
    small = frame[:20, :40]  # smaller than the 48 x 24 output
    np.testing.assert_array_equal(Preparer().prepare(small), _opencv_prepare(small, PreparationParams()))


@pytest.mark.parametrize("shape", [(480, 640), (960, 1920), (100, 97), (333, 1001), (24, 48), (20, 40), (31, 1000)])
def test_area_downsample_core_equals_opencv(shape):
    rng = np.random.default_rng(sum(shape))
    image = rng.integers(0, 256, shape, dtype=np.uint8)
    np.testing.assert_array_equal(area_downsample(image, 48, 24), area_downsample_opencv(image, 48, 24))
    deep = image.astype(np.uint16) * 200
    np.testing.assert_array_equal(area_downsample(deep, 48, 24), area_downsample_opencv(deep, 48, 24))


def test_opencv_grey_conversion_is_the_documented_fixed_point():
    """The core's grey formula, (3735 B + 19235 G + 9798 R + 16384) >> 15, is OpenCV's on every
    colour (2^24 colours in one 4096 x 4096 frame), in both channel orders."""
    v = np.arange(1 << 24, dtype=np.uint32)
    image = np.stack([v & 255, (v >> 8) & 255, v >> 16], axis=-1).astype(np.uint8).reshape(4096, 4096, 3)
    b, g, r = (image[..., i].astype(np.int64) for i in range(3))
    fixed_point = (b * 3735 + g * 19235 + r * 9798 + 16384) >> 15
    np.testing.assert_array_equal(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), fixed_point)
    params = PreparationParams(equalize="none", width=4096, height=4096, patch_normalize=False)
    np.testing.assert_array_equal(Preparer(params).prepare(image), cv2.cvtColor(image, cv2.COLOR_BGR2GRAY))
    rgb = PreparationParams(equalize="none", width=4096, height=4096, patch_normalize=False, channel_order="rgb")
    np.testing.assert_array_equal(Preparer(rgb).prepare(image), cv2.cvtColor(image, cv2.COLOR_RGB2GRAY))


def test_real_frames_prepare_identically(shared_data, simd_path):
    paths = sorted((shared_data / "gardens_point_pairs").rglob("*.png"))[:8]
    paths += sorted((shared_data / "nordland").rglob("*.png"))[:4]
    paths += sorted((shared_data / "golden").rglob("*.png"))[:4]
    frames = [cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in paths]
    frames = [f for f in frames if f is not None and f.dtype == np.uint8]
    if not frames:
        pytest.skip("no 8-bit PNG frames in the shared data")
    for frame in frames:
        for params in (
            PreparationParams(),
            PreparationParams(equalize="none", wrap=False),
            PreparationParams(crop=(0.1, 0.2, 0, 0)),
        ):
            np.testing.assert_array_equal(Preparer(params).prepare(frame), _opencv_prepare(frame, params))


def test_threads_prepare_concurrently():
    """Each thread has its own core workspace: eight threads give the serial bytes."""
    rng = np.random.default_rng(24)
    frames = [_frame(rng, 480, 640, 3, kind=k % 4) for k in range(8)]
    preparer = Preparer()
    expected = [preparer.prepare(f) for f in frames]
    results: dict = {}

    def work(i):
        results[i] = [preparer.prepare(frames[(i + k) % 8]) for k in range(20)]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i in range(8):
        for k, got in enumerate(results[i]):
            np.testing.assert_array_equal(got, expected[(i + k) % 8])


def _settings(**fields) -> _core.PrepareSettings:
    settings = _core.PrepareSettings()
    for name, value in fields.items():
        setattr(settings, name, value)
    return settings


def test_binding_errors_are_clear():
    frame = np.zeros((100, 120, 3), np.uint8)
    paper = _core.PrepareSettings()
    with pytest.raises(TypeError, match="uint8"):
        _core.prepare_frame(frame.astype(np.float32), "bgr", paper)
    with pytest.raises(ValueError, match="pixel order"):
        _core.prepare_frame(frame, "yuv", paper)
    with pytest.raises(ValueError, match=r"\(H, W, 4\)"):
        _core.prepare_frame(frame, "bgra", paper)
    with pytest.raises(ValueError, match="packed"):
        _core.prepare_frame(frame[:, ::2], "bgr", paper)
    with pytest.raises(ValueError, match="CLAHE"):
        _core.prepare_frame(frame, "bgr", _settings(equalize="clahe"))
    with pytest.raises(ValueError, match="removes the whole"):
        _core.prepare_frame(frame, "bgr", _settings(crop_top=60, crop_bottom=40))
    with pytest.raises(ValueError, match="only downsamples"):
        _core.prepare_frame(frame, "bgr", _settings(width=200))
    with pytest.raises(ValueError, match=r"^radius must be an integer in \[0, 1024\] pixels, got -1$"):
        _settings(radius=-1)  # a field is checked when set
    with pytest.raises(ValueError, match="equalize must be one of 'none', 'global', 'clahe', got 'histogram'"):
        _settings(equalize="histogram")
    with pytest.raises(ValueError, match="crop_left must be a non-negative integer, got -1"):
        _settings(crop_left=-1)
    assert _core.downsample_method(480, 640, 24, 48) == "integral"
    assert _core.downsample_method(20, 40, 24, 48) == "unsupported"
    # the Python API keeps its own messages
    with pytest.raises(ValueError, match="removes the whole"):
        nightloc.prepare(frame, PreparationParams(crop=(60, 40, 0, 0)))
