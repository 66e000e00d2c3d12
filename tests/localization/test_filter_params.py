"""The grid filter's parameters on their one path to the core: FilterParams takes the defaults and
ranges of the core's GridFilterSettings table, converts to it in one place
(FilterParams.core_settings), and a value out of range is an error in the table's words."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import nightloc
from nightloc import _core
from nightloc.localization.grid_filter import FilterParams
from nightloc.localization.localizer import LocalizationParams, Localizer
from nightloc.localization.odometry import NoiseModel

#: Core settings that FilterParams does not hold: the localizer's odometry noise (odometry_noise,
#: a noise model, step-scaled terms included) and its confidence radius (LocalizationParams).
_LOCALIZER_SETTINGS = {"distance_std", "heading_std", "distance_per_metre", "heading_per_radian", "confidence_radius"}


def test_python_defaults_are_the_cores_for_every_setting():
    core = _core.GridFilterSettings().to_dict()
    held = {f.name: f for f in dataclasses.fields(FilterParams) if f.name in core}
    assert set(held) == set(core) - _LOCALIZER_SETTINGS  # FilterParams names every other setting
    for name, field in held.items():
        assert field.default == core[name], name
        assert type(field.default) is type(core[name]), name  # counts int, the rest float
    for name in ("distance_per_metre", "heading_per_radian"):  # a Table III model leaves them at the core's 0
        assert getattr(NoiseModel(0.1, 0.02), name) == core[name], name
    assert LocalizationParams().confidence_radius == core["confidence_radius"]
    assert core["distance_std"] == core["heading_std"] == 0.0  # the localizer always sets its noise
    assert core["heading_bins"] == 0  # one bin per image column


def test_core_settings_is_the_conversion():
    params = FilterParams(likelihood_gain=2.5, heading_bins=24, settle_frames=3, field_of_view=60.0)
    settings = params.core_settings(NoiseModel(0.25, 0.05), 1.5)
    want = _core.GridFilterSettings().to_dict() | {
        "heading_bins": 24,
        "likelihood_gain": 2.5,
        "settle_frames": 3,
        "distance_std": 0.25,
        "heading_std": 0.05,
        "confidence_radius": 1.5,
    }
    assert settings.to_dict() == want
    assert list(settings.to_dict()) == list(want)  # the table's order: the map file's key order
    assert FilterParams().core_settings().to_dict() == _core.GridFilterSettings().to_dict()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"uniform_floor": 1.5}, r"^uniform_floor must be in \[0, 1\), got 1.5$"),
        (
            {"heading_bins": 5000},
            r"^heading_bins must be an integer in \[0, 4096\] \(0: one per image column\), got 5000$",
        ),
        ({"credibility": 0.0}, r"^credibility must be in \(0, 1\], got 0$"),
        ({"estimate_window": 1001}, r"^estimate_window must be an integer in \[0, 1000\] cells, got 1001$"),
        ({"negligible": 1.0}, r"^negligible must be in \[0, 1\), got 1$"),
        ({"settle_frames": 2000}, r"^settle_frames must be an integer in \[0, 1000\] frames, got 2000$"),
        ({"score_cap": -0.5}, r"^score_cap must be a finite number >= 0, got -0.5$"),
        (
            {"lookalike_places": 1.5},
            r"^lookalike_places must be 0 \(never tempered\) or a finite number >= 2, got 1.5$",
        ),
        ({"likelihood_gain": float("inf")}, r"^likelihood_gain must be a finite number >= 0, got inf$"),
        ({"heading_bins": -1}, r"^heading_bins must be an integer in \[0, 4096\] .*, got -1$"),
        ({"field_of_view": 400.0}, r"^field_of_view must be in \(0, 360\] degrees, got 400$"),
    ],
)
def test_the_tables_range_check_is_the_python_error(change, message):
    with pytest.raises(ValueError, match=message):
        FilterParams(**change)


def test_the_bound_settings_check_each_value_and_its_range():
    settings = _core.GridFilterSettings()
    settings.heading_bins = 24
    settings.position_floor = 0.1
    assert settings.heading_bins == 24 and settings.position_floor == 0.1
    with pytest.raises(_core.SettingError, match=r"^estimate_window must be a non-negative integer, got 2\.5$"):
        settings.estimate_window = 2.5
    with pytest.raises(_core.SettingError, match=r"^uniform_floor must be in \[0, 1\), got 1$") as error:
        settings.uniform_floor = 1.0  # the range is checked when set
    assert (error.value.setting, error.value.requirement) == ("uniform_floor", "must be in [0, 1), got 1")
    with pytest.raises(AttributeError):
        settings.likelyhood_gain = 1.0  # type: ignore[attr-defined]
    copy = pickle.loads(pickle.dumps(settings))
    assert copy.to_dict() == settings.to_dict()
    assert repr(copy).startswith("GridFilterSettings(heading_bins=24, likelihood_gain=3.0,")


def _map(columns: int) -> nightloc.ReferenceMap:
    rng = np.random.default_rng(5)
    n = 6
    images = rng.integers(0, 256, (n, 8, columns), dtype=np.uint8)
    positions = rng.uniform(0, 3, (n, 2))
    headings = rng.uniform(-np.pi, np.pi, n)
    params = nightloc.PreparationParams(width=columns, height=8)
    return nightloc.ReferenceMap(images, positions, headings, params=params)


@pytest.mark.parametrize("columns", [16, 40])
def test_heading_bins_zero_is_one_bin_per_image_column(columns):
    loc = Localizer(_map(columns), grid_width=10, grid_height=10)
    assert loc.grid_filter.settings.heading_bins == columns == loc.grid_filter.core.heading_bins
    loc = Localizer(_map(columns), grid_width=10, grid_height=10, heading_bins=12)
    assert loc.grid_filter.settings.heading_bins == 12 == loc.grid_filter.core.heading_bins


def test_no_settings_dict_reaches_the_core():
    loc = Localizer(_map(16), grid_width=10, grid_height=10)
    f = loc.grid_filter
    args = (f.mapper._core_weights, 0.0, 0.0, 1.0, 1.0, f.mapper.place_of_ref, None, 16, f.shifts)
    with pytest.raises(TypeError):
        _core.GridFilter(*args, f.settings.to_dict())  # type: ignore[arg-type]
    assert _core.GridFilter(*args, f.settings).heading_bins == 1  # no headings: position only
