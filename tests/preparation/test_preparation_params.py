"""Preparation parameters on their one path to the core: PreparationParams takes the defaults and
ranges of the core's PrepareSettings table, converts to it in one place
(PreparationParams.core_settings), and a value out of range is an error in the table's words."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from nightloc import PreparationParams, Preparer, _core

#: PreparationParams field -> the core's PrepareSettings field holding it (crop: four pixel fields).
_CORE_NAMES = {
    "width": "width",
    "height": "height",
    "radius": "radius",
    "wrap": "wrap",
    "equalize": "equalize",
    "patch_normalize": "patch_normalize",
    "scale": "scale",
}


def test_python_defaults_are_the_cores_for_every_setting():
    core = _core.PrepareSettings()
    defaults = {f.name: f.default for f in dataclasses.fields(PreparationParams)}
    for name, core_name in _CORE_NAMES.items():
        assert defaults[name] == getattr(core, core_name), name
        assert type(defaults[name]) is type(getattr(core, core_name)), name
    assert defaults["crop"] == (0, 0, 0, 0) == (core.crop_top, core.crop_bottom, core.crop_left, core.crop_right)
    assert (core.width, core.height, core.radius, core.equalize) == (48, 24, 4, "global")  # the paper's Table II


def test_core_settings_is_the_conversion():
    params = PreparationParams(
        width=64,
        height=16,
        radius=3,
        wrap=False,
        equalize="none",
        patch_normalize=False,
        scale=20.5,
        crop=(0.1, 0, 3, 0),
    )
    settings = params.core_settings((5, 0, 3, 0))
    got = {core_name: getattr(settings, core_name) for core_name in _CORE_NAMES.values()}
    assert got == {
        "width": 64,
        "height": 16,
        "radius": 3,
        "wrap": False,
        "equalize": "none",
        "patch_normalize": False,
        "scale": 20.5,
    }
    assert (settings.crop_top, settings.crop_bottom, settings.crop_left, settings.crop_right) == (5, 0, 3, 0)
    assert params.core_settings(patch_normalize=True).patch_normalize is True
    assert PreparationParams(equalize="clahe").core_settings().equalize == "clahe"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"width": 0}, r"^width must be an integer >= 1 pixels, got 0$"),
        ({"height": 0}, r"^height must be an integer >= 1 pixels, got 0$"),
        ({"width": -3}, r"^width must be an integer >= 1 pixels, got -3$"),
        ({"width": 8192, "height": 4096}, r"^width x height = 8192x4096 is too large: .* 16777216 pixels"),
        ({"radius": 2000}, r"^radius must be an integer in \[0, 1024\] pixels, got 2000$"),
        ({"radius": -1}, r"^radius must be an integer in \[0, 1024\] pixels, got -1$"),
        ({"scale": float("nan")}, r"^scale must be a finite number > 0, got nan$"),
        ({"scale": -2.0}, r"^scale must be a finite number > 0, got -2$"),
        ({"width": 2**64}, r"^width = 18446744073709551616 is too large for the core$"),
        ({"radius": 2**31}, r"^radius must be an integer in \[0, 1024\] pixels, got 2147483648$"),
        ({"radius": -(2**31) - 1}, r"^radius must be an integer in \[0, 1024\] pixels, got -2147483649$"),
    ],
)
def test_the_tables_range_check_is_the_python_error(change, message):
    with pytest.raises(ValueError, match=message):
        PreparationParams(**change)


def test_a_preparer_pickles_without_its_core_settings():
    preparer = Preparer(PreparationParams(width=32, height=16))
    frame = np.random.default_rng(3).integers(0, 256, (60, 80), dtype=np.uint8)
    first = preparer.prepare(frame)
    clone = pickle.loads(pickle.dumps(preparer))
    assert clone.params == preparer.params
    np.testing.assert_array_equal(clone.prepare(frame), first)
