"""``--shift-window COLUMNS,ROWS`` on the 2D filter's commands (localize, evaluate): the filter's
column window (forward cameras) and row window (tilt), as the API's ``FilterParams`` set them."""

from __future__ import annotations

import csv
import functools

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.localization.evaluation import EvaluationSettings, evaluate, match_traverse
from nightloc.localization.grid_filter import FilterParams
from nightloc.motion.odometry import log_noise_model, traverse_odometry

from synth_support import default_synth_data


@functools.lru_cache(maxsize=1)
def _forward_world(root: str) -> dict:
    from nightloc.synth import Camera, make_dataset

    return make_dataset("living_room", root, camera=Camera(48, 24), view="forward", threads=1)


@pytest.fixture(scope="module")
def forward(tmp_path_factory):
    folders = _forward_world(str(tmp_path_factory.mktemp("forward")))
    map_file = tmp_path_factory.mktemp("map") / "forward.map"
    assert main(["build-map", str(folders["day_reference"]), str(map_file), "--camera", "forward"]) == 0
    return folders, map_file


def _trajectory(path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))[1:]
    return np.array([[float(v) for v in row[1:4]] for row in rows])


def test_localize_takes_the_filters_window_as_the_api_does(forward, tmp_path):
    folders, map_file = forward
    out = tmp_path / "windowed"
    argv = ["localize", str(map_file), str(folders["night_query"]), "--no-figures", "--shift-window", "6,1"]
    assert main([*argv, "--out", str(out)]) == 0
    windowed = _trajectory(out / "trajectory.csv")

    ref_map = nightloc.ReferenceMap.load(map_file)
    log = nightloc.load_traverse(folders["night_query"])
    odometry = traverse_odometry(log)
    localizer = nightloc.Localizer(
        ref_map, odometry_noise=log_noise_model(odometry), filter_params=FilterParams(forward_window=6, row_window=1)
    )
    expected = np.array([[e.x, e.y, e.heading] for e in (localizer.update(f, odometry[i]) for i, f in log.frames())])
    np.testing.assert_allclose(windowed, expected, atol=1e-4)  # the CSV keeps 4 decimals

    plain = tmp_path / "plain"
    assert main(["localize", str(map_file), str(folders["night_query"]), "--no-figures", "--out", str(plain)]) == 0
    assert not np.allclose(_trajectory(plain / "trajectory.csv"), windowed, atol=1e-3)  # the option is not ignored


def test_evaluate_takes_the_filters_window_as_the_api_does(forward, tmp_path):
    folders, map_file = forward
    out = tmp_path / "eval"
    argv = ["evaluate", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(out)]
    options = ["--camera", "forward", "--method", "filter", "--odometry", "robot", "--noise-models", "0"]
    assert main([*argv, *options, "--no-figures", "--shift-window", "4,1"]) == 0
    with open(out / "errors.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    errors = np.array([float(row["error_m"]) for row in rows])

    ref_map = nightloc.ReferenceMap.load(map_file)
    params = FilterParams(forward_window=4, row_window=1)
    matches = match_traverse(ref_map, folders["night_query"], tables=True, filter_params=params)
    assert matches.tables.shape[2] == 2 * 4 + 1
    settings = EvaluationSettings(methods=("filter",), noise_models=(0,), odometry="robot", interpolation=(True, False))
    expected = evaluate(ref_map, matches, settings, filter_params=params).errors(method="filter")
    np.testing.assert_allclose(np.sort(errors), np.sort(expected.ravel()), atol=1e-3)


@pytest.mark.parametrize(
    ("window", "message"),
    [
        ("0,1", "column window must be 1..47"),
        ("6,24", "at most 23 rows"),
        ("6", "expected COLUMNS,ROWS"),
        ("a,b", "expected COLUMNS,ROWS"),
        ("-1,0", "expected COLUMNS,ROWS"),
    ],
)
def test_a_forward_maps_bad_window_is_one_line(forward, tmp_path, capsys, window, message):
    folders, map_file = forward
    out = tmp_path / "o"
    argv = ["localize", str(map_file), str(folders["night_query"]), "--out", str(out), f"--shift-window={window}"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "--shift-window" in err and err.count("\n") == 1
    assert not out.exists()  # nothing written


def test_a_panoramic_map_takes_rows_only(tmp_path, capsys):
    folders = default_synth_data()["garden"]
    argv = ["localize", str(folders["day_reference"]), str(folders["night_query"]), "--no-figures"]
    assert main([*argv, "--out", str(tmp_path / "bad"), "--shift-window", "8,1"]) == 2
    assert "--shift-window 0,1" in capsys.readouterr().err
    assert main([*argv, "--out", str(tmp_path / "rows"), "--shift-window", "0,1"]) == 0
    rows = _trajectory(tmp_path / "rows" / "trajectory.csv")

    ref_map = nightloc.ReferenceMap.build(folders["day_reference"])
    log = nightloc.load_traverse(folders["night_query"])
    odometry = traverse_odometry(log)
    noise = log_noise_model(odometry)  # what localize assumes for the log's odometry
    localizer = nightloc.Localizer(ref_map, odometry_noise=noise, filter_params=FilterParams(row_window=1))
    expected = np.array([[e.x, e.y, e.heading] for e in (localizer.update(f, odometry[i]) for i, f in log.frames())])
    np.testing.assert_allclose(rows, expected, atol=1e-4)  # the CSV keeps 4 decimals
