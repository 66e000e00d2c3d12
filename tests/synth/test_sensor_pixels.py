"""The sensor's pixel (full well, read noise) against analytic oracles: what the camera study varies."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nightloc.synth.sensor import FULL_WELL, READ_NOISE, Exposure, capture, metered_exposure


@pytest.mark.parametrize("full_well", [1000.0, 4000.0, 64000.0])
@pytest.mark.parametrize("darkness", [0.0, 1.0, 2.5])
def test_metered_electrons_scale_with_the_well(full_well, darkness):
    # The metered radiance lands at 18 % of the pixel's own well, times 10**(-2 d).
    exposure = metered_exposure(0.25, darkness, 2.2, full_well=full_well, read_noise=3.0)
    assert exposure.electrons_per_unit * 0.25 == pytest.approx(0.18 * full_well * 10.0 ** (-2 * darkness))
    assert exposure.full_well == full_well and exposure.read_noise == 3.0
    assert exposure.gain == pytest.approx(10.0**darkness)


def test_default_pixel_is_the_old_exposure():
    plain = metered_exposure(0.4, 1.0)
    assert (plain.full_well, plain.read_noise) == (FULL_WELL, READ_NOISE)


def _readable(exposure: Exposure, levels_per_electron: float) -> Exposure:
    """``exposure`` with linear output (gamma 1) and a gain giving ``levels_per_electron`` grey levels
    per electron, so that the uint8 output reads electrons back."""
    return replace(exposure, gamma=1.0, gain=levels_per_electron * exposure.full_well / 255.0)


@pytest.mark.parametrize(("full_well", "read_noise"), [(1000.0, 1.5), (16000.0, 3.0)])
def test_shot_and_read_noise_of_a_dark_pixel(full_well, read_noise):
    # the mean is the expected electrons, the variance Poisson + read noise + quantization (1/12 level²)
    darkness = 0.5 if full_well < 4000 else 1.0
    exposure = metered_exposure(1.0, darkness, 1.0, full_well=full_well, read_noise=read_noise)
    mean_electrons = 0.18 * full_well * 10.0 ** (-2 * darkness)
    per_electron = 150.0 / (mean_electrons + 6 * np.sqrt(mean_electrons + read_noise**2))
    exposure = _readable(exposure, per_electron)
    values = capture(np.full((300, 300, 3), 1.0, np.float32), exposure, np.random.default_rng(3)).astype(np.float64)
    electrons = values / per_electron
    assert electrons.mean() == pytest.approx(mean_electrons, rel=0.02)
    expected_var = mean_electrons + read_noise**2 + (1 / 12) / per_electron**2
    assert electrons.var() == pytest.approx(expected_var, rel=0.06)


def test_binning_equals_a_bigger_pixel():
    # k x k pixels summed collect k*k times the electrons with k*k times the shot noise variance and
    # k*k read noises: the same mean and variance as one pixel of k*k the area whose read noise is
    # k times larger (digital binning).
    k, small_well, read, per_electron = 4, 2000.0, 2.0, 0.3
    small = _readable(metered_exposure(1.0, 0.5, full_well=small_well, read_noise=read), per_electron)
    big = _readable(metered_exposure(1.0, 0.5, full_well=small_well * k * k, read_noise=read * k), per_electron)
    rng = np.random.default_rng(5)
    radiance = np.full((400, 400, 3), 1.0, np.float32)
    binned = capture(radiance, small, rng).astype(np.float64)[..., 0] / per_electron
    binned = binned.reshape(100, k, 100, k).sum(axis=(1, 3))
    single = capture(radiance[:100, :100], big, rng).astype(np.float64)[..., 0] / per_electron
    expected_mean = 0.18 * small_well * k * k / 10.0
    expected_var = expected_mean + k * k * read**2
    for values in (binned, single):
        assert values.mean() == pytest.approx(expected_mean, rel=0.02)
        assert values.var() == pytest.approx(expected_var, rel=0.1)
