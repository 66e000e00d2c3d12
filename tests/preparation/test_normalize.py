"""Patch normalization (eq. 1) and OpenSeqSLAM block normalization against numpy oracles."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from scipy.stats import spearmanr

import nightloc

import oracle

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize


@pytest.mark.parametrize(("h", "w"), [(24, 48), (1, 1), (3, 5), (9, 9), (10, 30), (31, 17)])
@pytest.mark.parametrize("radius", [0, 1, 4, 6])
@pytest.mark.parametrize("wrap", [True, False])
def test_patch_normalize_matches_oracle(h, w, radius, wrap):
    rng = np.random.default_rng(h * 100 + w + radius)
    image = rng.integers(0, 256, size=(h, w), dtype=np.uint8)
    expected = oracle.patch_normalize(image, radius, wrap, nightloc.DEFAULT_PATCH_SCALE)
    np.testing.assert_array_equal(nightloc.patch_normalize(image, radius=radius, wrap=wrap), expected)


def test_patch_normalize_stack_and_scale():
    rng = np.random.default_rng(1)
    stack = rng.integers(0, 40, size=(5, 24, 48), dtype=np.uint8)  # dark, low-contrast night frames
    out = nightloc.patch_normalize(stack, scale=40.0)
    assert out.shape == stack.shape and out.dtype == np.uint8
    for image, got in zip(stack, out):
        np.testing.assert_array_equal(got, oracle.patch_normalize(image, 4, True, 40.0))


def test_flat_windows_give_128_not_nan():
    flat = np.full((24, 48), 93, np.uint8)
    assert np.all(nightloc.patch_normalize(flat) == 128)
    half = flat.copy()
    half[:, 24:] = 200
    out = nightloc.patch_normalize(half, radius=2, wrap=False)
    assert out[12, 5] == 128 and out[12, 40] == 128  # far from the edge: flat windows
    assert out[12, 23] < 128 < out[12, 24]


def test_wrap_commutes_with_column_shifts():
    rng = np.random.default_rng(4)
    image = rng.integers(0, 256, size=(24, 48), dtype=np.uint8)
    for d in (1, 7, 30):
        np.testing.assert_array_equal(
            nightloc.patch_normalize(np.roll(image, d, axis=1)), np.roll(nightloc.patch_normalize(image), d, axis=1)
        )


def test_normalization_removes_brightness_and_contrast_changes():
    rng = np.random.default_rng(8)
    day = rng.integers(60, 200, size=(24, 48)).astype(np.float64)
    night = np.clip(0.25 * day - 10, 0, 255)  # a dark, low-contrast exposure of the same scene
    a = nightloc.patch_normalize(day.astype(np.uint8))
    b = nightloc.patch_normalize(np.round(night).astype(np.uint8))
    assert np.abs(a.astype(int) - b.astype(int)).mean() < 6


def _rank_agreement(images: np.ndarray) -> float:
    """Spearman correlation between pairwise SADs of quantized and of float z-images."""
    z = np.stack([oracle.patch_zscores(image, 4, True) for image in images])
    q = nightloc.patch_normalize(images).astype(np.float64)
    iu = np.triu_indices(len(images), 1)
    float_sad = np.abs(z[:, None] - z[None]).mean(axis=(2, 3))[iu]
    quant_sad = np.abs(q[:, None] - q[None]).mean(axis=(2, 3))[iu]
    return spearmanr(float_sad, quant_sad).correlation


def test_quantization_ranks_like_float_normalization():
    """The default scale keeps SAD rankings of the float eq. (1) images (chosen by this measure)."""
    rng = np.random.default_rng(12)
    blurred = cv2.GaussianBlur(rng.integers(0, 256, size=(40, 24, 48)).astype(np.float32), (0, 0), 1.5)
    images = np.clip(blurred * 3 - 250, 0, 255).astype(np.uint8)
    assert _rank_agreement(images) > 0.9995


def test_quantization_ranks_like_float_on_real_images(shared_data):
    images = []
    for path in sorted((shared_data / "gardens_point_pairs").glob("*/*.jpg")):
        gray = cv2.equalizeHist(cv2.imread(str(path), cv2.IMREAD_GRAYSCALE))
        images.append(cv2.resize(gray, (48, 24), interpolation=cv2.INTER_AREA))
    assert len(images) == 20
    assert _rank_agreement(np.stack(images)) > 0.9995


@pytest.mark.parametrize(("h", "w", "side"), [(32, 64, 8), (30, 70, 8), (7, 5, 2), (16, 16, 4), (9, 27, 3)])
def test_block_normalize_matches_oracle(h, w, side):
    rng = np.random.default_rng(h + w + side)
    image = rng.integers(0, 256, size=(h, w), dtype=np.uint8)
    image[:side, :side] = 77  # a flat block -> 0
    expected = oracle.block_normalize(image, side)
    got = nightloc.block_normalize(image, side=side)
    np.testing.assert_array_equal(got, expected)
    assert np.all(got[:side, :side] == 0)


def test_block_normalize_is_bit_exact_with_openseqslam_golden(shared_data):
    golden = shared_data / "golden" / "openseqslam_A"
    params = json.loads((golden / "params.json").read_text())
    for key, files in (("ref", params["reference_files"]), ("query", params["query_files"])):
        expected = np.load(golden / f"pre_{key}_all.npy")
        gray = np.stack(
            [
                oracle.octave_rgb2gray(cv2.cvtColor(cv2.imread(str(shared_data / "nordland" / f)), cv2.COLOR_BGR2RGB))
                for f in files
            ]
        )
        got = nightloc.block_normalize(gray, side=8)
        np.testing.assert_array_equal(got, expected)
        assert (got == 0).sum() == params[f"n_zero_pixels_pre_{key}"]
