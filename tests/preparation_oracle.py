"""numpy references for image preparation: exact area means, cv2.equalizeHist from its
definition, and a smooth synthetic panorama."""

from __future__ import annotations

import numpy as np


def area_weights(n_in: int, n_out: int) -> np.ndarray:
    """(n_out, n_in) float64: the fraction of input cell i inside output cell o, / cell size."""
    weights = np.zeros((n_out, n_in))
    size = n_in / n_out
    for o in range(n_out):
        start, stop = o * size, (o + 1) * size
        for i in range(int(np.floor(start)), min(n_in, int(np.ceil(stop)))):
            weights[o, i] = max(0.0, min(stop, i + 1) - max(start, i)) / size
    return weights


def area_oracle(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """Exact float64 area means, (height, width)."""
    return area_weights(image.shape[0], height) @ image.astype(np.float64) @ area_weights(image.shape[1], width).T


def equalize_oracle(grey: np.ndarray, levels: int) -> np.ndarray:
    """cv2.equalizeHist's mapping written from its definition: darkest present level -> 0,
    level v -> round(255 * (#pixels in (darkest, v]) / (#pixels above darkest))."""
    values = grey.reshape(-1).astype(np.int64)
    darkest = values.min()
    above = (values > darkest).sum()
    if above == 0:
        return np.full(grey.shape, min(int(darkest), 255), np.uint8)
    histogram = np.bincount(values, minlength=levels)
    counts = np.cumsum(histogram) - histogram[darkest]
    lut = np.clip(np.rint(counts.astype(np.float32) * np.float32(255.0 / above)), 0, 255)
    return lut[values].reshape(grey.shape).astype(np.uint8)


def panorama(height: int, width: int, seed: int) -> np.ndarray:
    """A smooth random 360-degree BGR panorama (periodic in x)."""
    rng = np.random.default_rng(seed)
    x = np.arange(width) * 2 * np.pi / width
    y = np.linspace(0, 1, height)[:, None]
    field = np.zeros((height, width))
    for harmonic in range(1, 7):
        field += (
            rng.uniform(10, 40)
            / harmonic
            * np.sin(harmonic * x[None, :] + rng.uniform(0, 2 * np.pi) + rng.uniform(-3, 3) * y)
        )
    grey = np.clip(110 + field, 0, 255)
    return np.dstack([grey * 0.9, grey, np.clip(grey * 1.1, 0, 255)]).astype(np.uint8)
