"""Numbers are checked where they enter: coordinates, margins, radii, odometry steps and
tolerances that are not finite or lie beyond ``MAX_COORDINATE_M`` (1e8 m) are refused when the
map, the traverse or the parameters are made -- naming the file and line for files -- instead of
escaping later as wrong answers or internal errors; a damaged dataset cache is rebuilt.

Old behaviour: map coordinates x 1e100 gave estimates off by 3.7x the map with no error, x 1e200
an IndexError, 1e17 offsets a ZeroDivisionError; ``poses.csv`` with x = 1e308 was accepted by
``build-map`` and failed later in scipy; ``route --tolerance inf`` was an "internal error:
OverflowError"; a damaged ``dataset.json`` in the cache made ``demo`` raise AttributeError.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import nightloc
from nightloc import DatasetError, _validate, route
from nightloc.cli import main
from nightloc.localization.heatmap import HeatGrid, HeatMapper

from reliability_support import Workspace


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    return Workspace(tmp_path_factory.mktemp("numbers"))


def _csv_with(ws, x: str) -> object:
    rows = ws.pose_rows().splitlines()
    name, _, y, heading = rows[3].split(",")
    rows[3] = ",".join([name, x, y, heading])
    return ws.traverse_variant("\n".join(rows) + "\n")


REFUSED = [
    ("map positions x 1e100", lambda ws: nightloc.ReferenceMap(ws.map.images, ws.map.positions * 1e100), "1e8"),
    ("map positions x 1e200", lambda ws: nightloc.ReferenceMap(ws.map.images, ws.map.positions * 1e200), "1e8"),
    ("map positions + 1e17", lambda ws: nightloc.ReferenceMap(ws.map.images, ws.map.positions + 1e17), "1e8"),
    ("poses.csv x = 1e308", lambda ws: nightloc.load_traverse(_csv_with(ws, "1e308")), "line 4"),
    ("poses.csv x = -2e8", lambda ws: nightloc.load_traverse(_csv_with(ws, "-2e8")), "MAX_COORDINATE_M"),
    (
        "save_traverse positions 1e9",
        lambda ws: nightloc.save_traverse(ws.fresh("t"), ws.frames[:1], [[1e9, 0.0]]),
        "positions[0]",
    ),
    ("heat-map positions 1e300", lambda ws: HeatMapper([[0.0, 0.0], [1e300, 1.0]]), "positions[1]"),
    ("grid margin 1e300", lambda ws: HeatGrid.spanning(ws.map.positions, margin=1e300), "margin"),
    ("localization margin 1e300", lambda ws: nightloc.LocalizationParams(margin=1e300), "margin"),
    ("confidence radius 1e9", lambda ws: nightloc.LocalizationParams(confidence_radius=1e9), "confidence_radius"),
    ("odometry step 1e300 m", lambda ws: nightloc.MapDisplacement(1e300, 0.0), "dx"),
    ("robot motion 2e8 m ahead", lambda ws: nightloc.RobotMotion(2e8), "forward"),
    ("odometry pair (0, 1e12)", lambda ws: _localizer(ws).update(ws.frames[1], (0.0, 1e12)), "dy"),
    ("route tolerance 2e8", lambda ws: _ground_truth(2e8), "tolerance"),
    ("route tolerance 1e300", lambda ws: _ground_truth(1e300), "tolerance"),
    ("route positions 1e9", lambda ws: route.GroundTruth.from_positions([[1e9, 0]], [[0, 0]], 3.0), "1e8"),
]


def _localizer(ws):
    localizer = nightloc.Localizer(ws.map, grid_width=40, grid_height=30)
    localizer.update(ws.frames[0])
    return localizer


def _ground_truth(tolerance):
    return route.GroundTruth.from_positions(np.zeros((3, 2)), np.zeros((4, 2)), tolerance)


@pytest.mark.sanitize  # the localizer cases drive the core (CI runs them again under ASan + UBSan)
@pytest.mark.parametrize("case", REFUSED, ids=[c[0] for c in REFUSED])
def test_numbers_are_refused_where_they_enter(ws, case):
    _, call, words = case
    with pytest.raises(ValueError, match=re.escape(words)) as info:
        call(ws)
    assert "\n" not in str(info.value)


@pytest.mark.sanitize
def test_the_bound_keeps_projected_coordinates(ws):
    """UTM northings (to 1e7 m) and Web Mercator (to 2e7 m) stay accepted, and answer as the same
    map at the origin does (moved by the offset)."""
    for offset in ((5e5, 1e7), (-2.0e7, 2.0e7)):
        far = nightloc.ReferenceMap(ws.map.images, ws.map.positions + offset, ws.map.headings)
        near = nightloc.Localizer(ws.map, grid_width=40, grid_height=30).update(ws.frames[2])
        moved = nightloc.Localizer(far, grid_width=40, grid_height=30).update(ws.frames[2])
        assert (moved.x - offset[0], moved.y - offset[1]) == pytest.approx((near.x, near.y), abs=1e-4)
    assert _validate.MAX_COORDINATE_M == 1e8


def test_poses_csv_beyond_the_bound_names_file_and_line(ws):
    root = _csv_with(ws, "1e308")
    with pytest.raises(DatasetError) as info:
        nightloc.load_traverse(root)
    assert str(root / "poses.csv") in str(info.value) and "line 4" in str(info.value)


@pytest.mark.parametrize("tolerance", ["inf", "nan", "-inf", "1e300"])
def test_route_tolerance_not_finite_is_a_one_line_error(ws, tmp_path, capsys, tolerance):
    """Old behaviour: ``--tolerance inf`` ended in "internal error: OverflowError", exit 1."""
    longer = nightloc.save_traverse(tmp_path / "t", [*ws.frames, *ws.frames[::-1]] * 2, np.zeros((24, 2)) + 1.0)
    argv = ["route", str(longer.root), str(longer.root), "--out", str(tmp_path / "o"), "--ds", "4"]
    assert main([*argv, "--ground-truth", "frames", f"--tolerance={tolerance}"]) == 2
    err = capsys.readouterr().err
    assert "--tolerance" in err and "internal error" not in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


DAMAGES = {
    "a list": b"[1, 2, 3]",
    "traverses a list": b'{"traverses": [1]}',
    "a traverse a number": b'{"traverses": {"day_reference": 7}}',
    "not UTF-8": b"\xff\xfe not json",
    "empty": b"",
}


@pytest.fixture(scope="module")
def tiny_cache(tmp_path_factory):
    """The default dataset's layout rendered at 16 x 8 pixels (fast), in its own cache folder."""
    import nightloc.synth.dataset as dataset
    from nightloc.synth.render import Camera

    real = dataset.make_dataset
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(dataset, "make_dataset", lambda *a, **k: real(*a, camera=Camera(16, 8), **k))
        return dataset.default_dataset(cache_dir=tmp_path_factory.mktemp("cache"))


@pytest.mark.parametrize("damage", list(DAMAGES))
def test_a_damaged_cache_description_reads_as_incomplete(tiny_cache, damage):
    """Old behaviour: ``demo`` raised AttributeError on a ``dataset.json`` holding a list or the
    wrong types (bytes that are not JSON were already caught: those rows guard the rewrite)."""
    from nightloc.synth import dataset

    folder = tiny_cache["garden"]["day_reference"].parents[1]
    description = folder / "garden" / "dataset.json"
    good = description.read_bytes()
    try:
        description.write_bytes(DAMAGES[damage])
        assert not dataset._complete(folder)
    finally:
        description.write_bytes(good)
    assert dataset._complete(folder)


def test_a_damaged_cache_is_rebuilt(tmp_path, monkeypatch):
    import nightloc.synth.dataset as dataset
    from nightloc.synth.render import Camera

    real = dataset.make_dataset
    monkeypatch.setattr(dataset, "make_dataset", lambda *a, **k: real(*a, camera=Camera(16, 8), **k))
    first = dataset.default_dataset(cache_dir=tmp_path)
    description = first["garden"]["day_reference"].parent / "dataset.json"
    good = description.read_bytes()
    description.write_bytes(DAMAGES["a list"])
    again = dataset.default_dataset(cache_dir=tmp_path)
    assert again == first and description.read_bytes() == good
    frames = json.loads(good)["traverses"]["day_reference"]["frames"]
    assert frames == len(nightloc.load_traverse(again["garden"]["day_reference"]))
    assert sorted(p.name for p in tmp_path.iterdir()) == [first["garden"]["day_reference"].parents[1].name]
