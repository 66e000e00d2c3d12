"""nightloc.synth lighting and sensor: shadows and fall-off against geometry, noise statistics
against Poisson, and night frames that are really dark and noisy."""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import pytest

from nightloc.synth import SynthScene
from nightloc.synth.geometry import box
from nightloc.synth.lighting import ground_irradiance, make_lighting
from nightloc.synth.sensor import FULL_WELL, Exposure, capture, metered_exposure
from nightloc.synth.world import LightSource

from synth_support import bare_world

POSES = {"garden": (3.5, 2.5, 0.3), "living_room": (2.0, 1.5, 1.0)}


def grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float64)


def brightness_and_snr(scene: SynthScene, condition: str, pose) -> tuple:
    """Mean grey level of the noiseless frame and its ratio to the rms sensor noise (3 draws)."""
    clean = grey(scene.frame(condition, *pose))
    noise = [grey(scene.frame(condition, *pose, rng=np.random.default_rng(k))) - clean for k in range(3)]
    rms = math.sqrt(float(np.mean(np.square(noise))))
    return float(clean.mean()), float(clean.mean()) / rms


# --- ground light: shadows and fall-off -------------------------------------------------------


def test_sun_shadow_of_a_box_falls_where_the_projection_says():
    world = bare_world([box(0.0, 0.0, 1.0, 1.0, 0.0, 2.0, "grey")])
    elevation = math.radians(45.0)
    sun_direction = np.array([math.cos(elevation), 0.0, math.sin(elevation)])  # sun in the east
    irradiance = ground_irradiance(world, np.full(3, 0.5), sun_direction, np.full(3, 3.0))
    lit = 0.5 + 3.0 * math.sin(elevation)

    def at(x, y):
        return float(irradiance.sample(np.array([x]), np.array([y]))[0, 0])

    # The 2 m box's shadow reaches 2 m west of it: x in [-2, 1], y in [0, 1].
    for x, y in [(-0.5, 0.5), (-1.8, 0.5), (-1.0, 0.2)]:
        assert at(x, y) == pytest.approx(0.5, abs=1e-3)
    for x, y in [(-2.3, 0.5), (1.3, 0.5), (-1.0, 1.3), (-1.0, -0.3)]:
        assert at(x, y) == pytest.approx(lit, abs=1e-3)


def test_lamp_light_falls_off_with_inverse_square_and_is_blocked():
    world = bare_world([box(3.0, -0.5, 3.2, 0.5, 0.0, 1.0, "grey")])
    lamp = LightSource((0.0, 0.0, 2.0), (1.0, 1.0, 1.0), ("night",))
    irradiance = ground_irradiance(world, np.zeros(3), lamps=[("lamp", lamp)])
    for x, y in [(0.05, 0.05), (1.0, -1.5), (-2.5, 2.0), (0.0, 4.0)]:
        d2 = x * x + y * y + 4.0
        expected = 2.0 / d2**1.5  # power * cos(incidence) / d^2
        assert irradiance.sample(np.array([x]), np.array([y]))[0, 0] == pytest.approx(expected, rel=0.03)
    # Behind the 1 m wall at x = 3.1 the shadow spans x from 3.2 to 2 * 3.2 / (2 - 1) = 6.4 m.
    assert irradiance.sample(np.array([5.0]), np.array([0.0]))[0, 0] < 1e-4
    beyond = irradiance.sample(np.array([7.0]), np.array([0.0]))[0, 0]
    assert beyond == pytest.approx(2.0 / (49.0 + 4.0) ** 1.5, rel=0.03)


def test_sun_patches_through_the_living_room_window_by_day_only():
    scene = SynthScene("living_room", seed=0)
    day = scene.lighting["day"]
    s = day.sun_direction
    assert s[1] < 0 and s[2] > 0  # the sun is in the south, above the horizon

    def floor_point(height_at_wall: float) -> tuple:
        # Follow the sun ray back from the inner face of the south wall (y = -0.9) at x = 1.25
        # (the middle of the west window, opening 0.9..2.1 m high) down to the floor.
        t = height_at_wall / s[2]
        return 1.25 - t * s[0], -0.9 - t * s[1]

    sun_only = ground_irradiance(scene.world, np.zeros(3), s, day.sun)

    def at(point):
        return float(sun_only.sample(np.array([point[0]]), np.array([point[1]]))[0, 0])

    assert at(floor_point(1.5)) == pytest.approx(day.sun[0] * s[2], rel=0.02)  # through the glass
    assert at(floor_point(2.35)) == pytest.approx(0.0, abs=1e-3)  # blocked by the lintel
    assert at(floor_point(0.5)) == pytest.approx(0.0, abs=1e-3)  # blocked by the wall under the sill
    night = scene.lighting["night"]
    assert night.sun_direction is None and not any(lamp.conditions == ("day",) for lamp in night.lamps)


# --- the sensor ---------------------------------------------------------------------------------


def test_capture_tone_curve_and_bgr_order():
    radiance = np.zeros((4, 6, 3), np.float32)
    radiance[..., 0] = 0.5  # red only
    exposure = Exposure(electrons_per_unit=1000.0, gain=2.0, gamma=2.2)
    image = capture(radiance, exposure)
    expected = 255.0 * (2.0 * 500.0 / FULL_WELL) ** (1 / 2.2)
    assert image.dtype == np.uint8 and image.shape == (4, 6, 3)
    assert np.all(np.abs(image[..., 2].astype(float) - expected) <= 0.6)
    assert np.all(image[..., :2] == 0)
    assert np.all(capture(radiance * 100, exposure)[..., 2] == 255)  # saturates, no wrap-around


@pytest.mark.parametrize(("electrons", "read_noise"), [(5.0, 0.0), (100.0, 0.0), (8.0, 1.0), (40.0, 3.0)])
def test_capture_noise_is_poisson_plus_read_noise(electrons, read_noise):
    # gamma 1, full well 255 and gain 1: the output grey level is the electron count.
    exposure = Exposure(electrons_per_unit=1.0, gain=1.0, gamma=1.0, full_well=255.0, read_noise=read_noise)
    radiance = np.full((200, 200, 3), electrons, np.float32)
    values = capture(radiance, exposure, np.random.default_rng(7)).astype(np.float64)
    assert values.mean() == pytest.approx(electrons, abs=0.06 + 0.01 * electrons)
    expected_variance = electrons + read_noise**2 + 1 / 12
    assert values.var() == pytest.approx(expected_variance, rel=0.05)


def test_metered_exposure_darkness():
    base = metered_exposure(0.5)
    dark = metered_exposure(0.5, darkness=1.0)
    assert base.electrons_per_unit * 0.5 == pytest.approx(0.18 * FULL_WELL)
    assert dark.electrons_per_unit == pytest.approx(base.electrons_per_unit / 100)
    assert dark.gain == pytest.approx(10.0)
    for bad in (-0.1, 3.5, float("nan")):
        with pytest.raises(ValueError, match="darkness"):
            metered_exposure(0.5, darkness=bad)
    with pytest.raises(ValueError, match="electrons_per_unit"):
        Exposure(electrons_per_unit=0.0)


# --- night frames are dark and noisy ------------------------------------------------------------


@pytest.mark.parametrize("world", ["garden", "living_room"])
def test_night_frames_are_dark_and_noisy(world):
    scene = SynthScene(world, seed=0)  # default darkness
    day_mean, day_snr = brightness_and_snr(scene, "day", POSES[world])
    night_mean, night_snr = brightness_and_snr(scene, "night", POSES[world])
    print(f"{world}: day mean {day_mean:.1f} SNR {day_snr:.1f}; night mean {night_mean:.1f} SNR {night_snr:.1f}")
    assert day_mean > 80 and day_snr > 40
    assert night_mean < 0.35 * day_mean
    assert night_snr < 8 and night_snr < day_snr / 8


def test_darkness_sweep_darkens_and_adds_noise():
    means, snrs = [], []
    for darkness in (0.0, 0.5, 1.0, 1.5):
        mean, snr = brightness_and_snr(SynthScene("garden", seed=0, darkness=darkness), "night", POSES["garden"])
        means.append(mean)
        snrs.append(snr)
    assert all(a > b for a, b in itertools.pairwise(means)), means
    assert all(a > b for a, b in itertools.pairwise(snrs)), snrs


def test_day_and_night_light_the_world_differently():
    scene = SynthScene("garden", seed=0)
    world = scene.world
    day, night = scene.lighting["day"], scene.lighting["night"]
    # The lawn by day: sunlit and shadowed parts; at night: lamps, well over 10x darker.
    day_light = day.ground.values / np.maximum(world.ground.values, 1e-4)
    night_light = night.ground.values / np.maximum(world.ground.values, 1e-4)
    assert day_light.max() / np.percentile(day_light, 5) > 3
    assert np.median(night_light) < np.median(day_light) / 30
    # The sky: bright by day, dark at night.
    assert day.sky.values.mean() > 100 * night.sky.values.mean()
    # A different seed moves the sun (and so the shadows).
    other = make_lighting(world, "day", seed=1)
    assert not np.allclose(other.sun_direction, day.sun_direction)
