"""A map keeps the localizer's settings it was built with: ReferenceMap.settings round-trips
through the file, ``Localizer(map)`` runs them (a FilterParams given replaces them, keyword
overrides change single fields), a map without them loads with the defaults, and the commands
store them (``build-map --params``/``--set``) and run them (``localize``), saying where each came
from."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.io.map_file import read_map_file, write_map_file

from synth_support import default_synth_data


def _map(**settings) -> nightloc.ReferenceMap:
    rng = np.random.default_rng(3)
    n = 9
    images = rng.integers(0, 256, (n, 8, 16), dtype=np.uint8)
    positions = np.column_stack([np.arange(n) % 3, np.arange(n) // 3]).astype(float)
    params = nightloc.PreparationParams(width=16, height=8)
    return nightloc.ReferenceMap(images, positions, rng.uniform(-3, 3, n), params=params, settings=settings or None)


def test_settings_round_trip_through_the_file(tmp_path):
    tuned = nightloc.FilterParams(uniform_floor=0.05, heading_bins=8)
    ref_map = _map(filter=tuned, localization={"grid_width": 20, "grid_height": 12})
    assert ref_map.settings == {
        "filter": nightloc.config.params_to_dict(tuned),
        "localization": {"grid_width": 20, "grid_height": 12},
    }
    loaded = nightloc.ReferenceMap.load(ref_map.save(tmp_path / "m.map"))
    assert loaded.settings["filter"] == nightloc.config.params_to_dict(tuned)
    assert loaded.settings["localization"]["grid_width"] == 20
    header = read_map_file(tmp_path / "m.map")[1]["localizer"]
    assert (header["settings"]["uniform_floor"], header["settings"]["heading_bins"]) == (0.05, 8)  # the firmware's
    assert (header["grid"]["width"], header["grid"]["height"]) == (20, 12)
    assert loaded == ref_map.with_settings(nightloc.LocalizationParams(grid_width=20, grid_height=12), tuned)
    assert loaded != _map()


def test_bad_settings_are_refused_by_name():
    with pytest.raises(ValueError, match=r"uniform_floor must be in \[0, 1\), got 2"):
        _map(filter={"uniform_floor": 2.0})
    with pytest.raises(ValueError, match=r"unknown key 'uniform_flor' in \[filter\]"):
        _map(filter={"uniform_flor": 0.1})
    with pytest.raises(ValueError, match=r"keeps the settings \[localization\], \[filter\], not \[route\]"):
        _map(route={"vmin": 0.5})


def test_the_localizer_runs_the_maps_settings():
    ref_map = _map(filter={"uniform_floor": 0.05, "likelihood_gain": 2.0}, localization={"grid_width": 20})
    loc = nightloc.Localizer(ref_map)
    assert (loc.filter_params.uniform_floor, loc.filter_params.likelihood_gain, loc.params.grid_width) == (
        0.05,
        2.0,
        20,
    )
    assert loc.grid_filter.settings.uniform_floor == 0.05
    # keyword overrides change single fields of the map's
    loc = nightloc.Localizer(ref_map, likelihood_gain=2.5)
    assert (loc.filter_params.uniform_floor, loc.filter_params.likelihood_gain) == (0.05, 2.5)
    # a FilterParams given replaces the map's section as a whole
    loc = nightloc.Localizer(ref_map, filter_params=nightloc.FilterParams())
    assert loc.filter_params == nightloc.FilterParams() and loc.params.grid_width == 20


def test_a_map_without_stored_settings_loads_with_the_defaults(tmp_path):
    path = _map(filter={"uniform_floor": 0.05}).save(tmp_path / "m.map")
    _, header, arrays = read_map_file(path)
    kept = dict(header["localizer"])
    # a changed setting is refused, as a changed array is
    header["localizer"]["filter"]["uniform_floor"] = 0.06
    write_map_file(tmp_path / "damaged.map", header, arrays, overwrite=False)
    with pytest.raises(nightloc.MapFormatError, match="checksum of the localizer's settings does not match"):
        nightloc.ReferenceMap.load(tmp_path / "damaged.map")
    header["localizer"] = kept
    # as maps written before they were read: the records and their checksum absent
    for key in ("filter", "localization", "settings_checksum"):
        del header["localizer"][key]
    write_map_file(tmp_path / "old.map", header, arrays, overwrite=False)
    old = nightloc.ReferenceMap.load(tmp_path / "old.map")
    assert old.settings == {}
    assert nightloc.Localizer(old).filter_params == nightloc.FilterParams()
    # settings this nightloc does not know are named, with the version that wrote them
    header["localizer"]["filter"] = {"uniform_floor": 0.05, "new_knob": 1}
    write_map_file(tmp_path / "newer.map", header, arrays, overwrite=False)
    with pytest.raises(nightloc.MapFormatError, match=r"unknown key 'new_knob' in \[filter\].*written by nightloc"):
        nightloc.ReferenceMap.load(tmp_path / "newer.map")


def _trajectory(path):
    with open(path, newline="") as handle:
        return np.array([[float(r[k]) for k in ("x", "y", "heading", "confidence")] for r in csv.DictReader(handle)])


def test_build_map_keeps_params_and_set_and_localize_runs_them(tmp_path, capsys):
    folders = default_synth_data()["garden"]
    tuned = tmp_path / "tuned.toml"
    tuned.write_text("[filter]\nuniform_floor = 0.05\nheading_bins = 24\n")
    map_file = tmp_path / "garden.map"
    argv = ["build-map", str(folders["day_reference"]), str(map_file), "--params", str(tuned)]
    assert main([*argv, "--set", "filter.likelihood_gain=2.5"]) == 0
    printed = capsys.readouterr().out
    assert f"localizer settings kept in the map: {tuned}: [filter] uniform_floor = 0.05, heading_bins = 24" in printed
    assert "--set: [filter] likelihood_gain = 2.5" in printed
    stored = json.loads(np.load(map_file)["header"].tobytes())["localizer"]["settings"]
    assert (stored["uniform_floor"], stored["heading_bins"], stored["likelihood_gain"]) == (0.05, 24, 2.5)
    # localize runs the map's settings and says so
    run = ["localize", str(map_file), str(folders["night_query"]), "--no-figures"]
    assert main([*run, "--out", str(tmp_path / "a")]) == 0
    printed = capsys.readouterr().out
    assert f"settings: the map {map_file}: [filter] heading_bins = 24, likelihood_gain = 2.5, uniform_floor = 0.05" in (
        printed
    )
    loc = nightloc.Localizer(
        nightloc.ReferenceMap.load(map_file), odometry_noise=nightloc.motion.odometry.WHEEL_ODOMETRY_NOISE
    )
    log = nightloc.load_traverse(folders["night_query"])
    odometry = nightloc.traverse_odometry(log)
    api = np.array([(e.x, e.y, e.heading, e.confidence) for e in (loc.update(f, odometry[i]) for i, f in log.frames())])
    np.testing.assert_allclose(_trajectory(tmp_path / "a" / "trajectory.csv"), api, atol=5e-5)
    # --set replaces one key of the map's, the rest stay the map's
    assert main([*run, "--out", str(tmp_path / "b"), "--set", "filter.uniform_floor=0.02"]) == 0
    printed = capsys.readouterr().out
    assert "--set: [filter] uniform_floor = 0.02" in printed and "heading_bins = 24" in printed
    tuned_again = nightloc.Localizer(
        nightloc.ReferenceMap.load(map_file),
        odometry_noise=nightloc.motion.odometry.WHEEL_ODOMETRY_NOISE,
        uniform_floor=0.02,
    )
    api = np.array(
        [(e.x, e.y, e.heading, e.confidence) for e in (tuned_again.update(f, odometry[i]) for i, f in log.frames())]
    )
    np.testing.assert_allclose(_trajectory(tmp_path / "b" / "trajectory.csv"), api, atol=5e-5)
    # --set errors are the parameter file's
    assert main([*run, "--out", str(tmp_path / "c"), "--set", "filter.uniform_floor=1.5"]) == 2
    assert (
        "--set filter.uniform_floor=1.5: [filter] uniform_floor must be in [0, 1), got 1.5" in capsys.readouterr().err
    )
