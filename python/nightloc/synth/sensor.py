"""The camera sensor: exposure, shot and read noise, digital gain, tone curve, 8-bit output.

A pixel of scene radiance ``L`` (linear units, see :mod:`nightloc.synth.lighting`) collects
``N ~ Poisson(k * L)`` photo-electrons (``k`` = :attr:`Exposure.electrons_per_unit`, clipped at
the full well; drawn exactly below 12 electrons, as its normal limit above), gains Gaussian read
noise, is amplified by the digital ``gain``, normalized by the full well, clipped to [0, 1] and
quantized to 16 bits, encoded with the tone curve ``value ** (1 / gamma)`` and rounded to ``uint8``.

Night darkness. A day frame is exposed so that the metered scene radiance collects 18 % of the
full well (:func:`metered_exposure`). At night the camera meters the (much dimmer) night scene
the same way but, with ``darkness = d``, collects only ``10**(-2 d)`` of those electrons and
brightens them by ``10**d`` only: ``d = 0`` exposes the night like a day frame (only the
lighting differs), ``d = 1`` gives 100 times fewer photons (shot noise 10 times larger relative
to the signal) and an image about 10 times darker in linear terms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FULL_WELL", "MAX_DARKNESS", "READ_NOISE", "Exposure", "capture", "metered_exposure"]

FULL_WELL = 4000.0  # electrons at the brightest output level
READ_NOISE = 2.5  # electrons rms
METER_TARGET = 0.18  # metered radiance -> 18 % of the full well
#: The darkest night the sensor model renders: 10^-6 of the metered photons (each step of 1 is 100x fewer).
MAX_DARKNESS = 3.0


@dataclass(frozen=True)
class Exposure:
    """Sensor settings of one traverse.

    Attributes:
        electrons_per_unit: photo-electrons per unit of scene radiance.
        gain: digital gain after read-out (1 = none).
        gamma: tone curve exponent (output = linear ** (1 / gamma)).
        full_well: electrons that map to output 1.0 (before gain).
        read_noise: rms read noise, electrons.
    """

    electrons_per_unit: float
    gain: float = 1.0
    gamma: float = 2.2
    full_well: float = FULL_WELL
    read_noise: float = READ_NOISE

    def __post_init__(self) -> None:
        for name in ("electrons_per_unit", "gain", "gamma", "full_well"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"exposure {name} must be a positive finite number, got {value!r}")
        if not (np.isfinite(self.read_noise) and self.read_noise >= 0):
            raise ValueError(f"exposure read_noise must be >= 0, got {self.read_noise!r}")


def metered_exposure(
    metered_radiance: float,
    darkness: float = 0.0,
    gamma: float = 2.2,
    *,
    full_well: float = FULL_WELL,
    read_noise: float = READ_NOISE,
) -> Exposure:
    """The exposure for a scene whose metered (highlight-clipped mean) radiance is given.

    Args:
        metered_radiance: scene radiance that should land at 18 % of the full well at darkness 0.
        darkness: night darkness ``d >= 0``: ``10**(-2d)`` times the electrons, gain ``10**d``.
        gamma: tone-curve exponent.
        full_well: the pixel's full well, electrons. A pixel of ``a`` times the area holds ``a``
            times the electrons and, with the same lens and exposure time, collects ``a`` times the
            photons: ``electrons_per_unit`` scales with ``full_well``, so every sensor meters the
            same scene to 18 % of its own well.
        read_noise: rms read noise of the pixel, electrons.
    """
    if not (np.isfinite(metered_radiance) and metered_radiance > 0):
        raise ValueError(f"metered radiance must be positive, got {metered_radiance!r}")
    if not (np.isfinite(darkness) and 0.0 <= darkness <= MAX_DARKNESS):
        raise ValueError(f"darkness must be a number in [0, {MAX_DARKNESS:g}], got {darkness!r}")
    electrons = METER_TARGET * full_well / metered_radiance * 10.0 ** (-2.0 * darkness)
    return Exposure(
        electrons_per_unit=electrons, gain=10.0**darkness, gamma=gamma, full_well=full_well, read_noise=read_noise
    )


def capture(radiance: np.ndarray, exposure: Exposure, rng: np.random.Generator | None = None) -> np.ndarray:
    """Sensor read-out of a ``(H, W, 3)`` linear RGB radiance image: ``(H, W, 3)`` uint8 **BGR**.

    ``rng`` draws shot (Poisson) and read (Gaussian) noise; None gives the noiseless expectation.
    """
    expected = np.clip(radiance.astype(np.float64) * exposure.electrons_per_unit, 0.0, exposure.full_well)
    if rng is None:
        electrons = expected
    else:
        # Shot noise: exact Poisson counts where few electrons arrive, its normal limit elsewhere.
        gaussian = rng.standard_normal(expected.shape, dtype=np.float32)
        electrons = expected + gaussian * np.sqrt(expected)
        few = np.flatnonzero(expected.ravel() < _POISSON_BELOW)
        if few.size:
            electrons.ravel()[few] = rng.poisson(expected.ravel()[few])
        electrons += rng.standard_normal(expected.shape, dtype=np.float32) * np.float32(exposure.read_noise)
    levels = _TONE_LEVELS - 1
    code = np.clip(electrons * (exposure.gain * levels / exposure.full_well), 0.0, levels)
    encoded = _tone_curve(exposure.gamma)[np.floor(code + 0.5).astype(np.intp)]
    return np.ascontiguousarray(encoded[..., ::-1])


_TONE_LEVELS = 1 << 16
_POISSON_BELOW = 12.0  # electrons; above, Poisson(m) is drawn as m + sqrt(m) * N(0, 1)
_TONE_CURVES: dict = {}


def _tone_curve(gamma: float) -> np.ndarray:
    """uint8 output of each of 65 536 linear levels: ``round(255 * (level / 65535) ** (1 / gamma))``."""
    curve = _TONE_CURVES.get(gamma)
    if curve is None:
        linear = np.arange(_TONE_LEVELS) / (_TONE_LEVELS - 1)
        curve = np.floor(255.0 * linear ** (1.0 / gamma) + 0.5).astype(np.uint8)
        _TONE_CURVES[gamma] = curve
    return curve
