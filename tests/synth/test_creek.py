"""The creek world: 500 m of unlit path, the paper's frame counts, ground-truth positions."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from nightloc.cli import main
from nightloc.io.traverse import load_traverse
from nightloc.route.odometry import route_odometry
from nightloc.synth.creek import (
    CREEK_FRAMES,
    CREEK_LENGTH_M,
    DAY_LANE,
    NIGHT_LANE,
    PATH_HALF_WIDTH,
    build_creek,
    creek_drive,
    make_creek_dataset,
)
from nightloc.synth.geometry import Cylinder


@pytest.fixture(scope="module")
def creek():
    return build_creek(0)


def test_the_paper_table_one_frame_counts():
    assert CREEK_FRAMES == {"day_reference": 272, "night_query": 315}


def test_path_trees_structures_and_no_lamps(creek):
    x0, y0, x1, y1 = creek.mapped_area
    assert (x0, x1) == (0.0, CREEK_LENGTH_M) and y1 - y0 == pytest.approx(2 * PATH_HALF_WIDTH)
    assert creek.lights == {}  # unlit: only the night sky
    trunks = [o for o in creek.objects if isinstance(o, Cylinder) and o.material.startswith("bark")]
    assert len(trunks) > 150  # trees along the whole 500 m
    xs = np.array([o.center[0] for o in trunks])
    assert np.histogram(xs, bins=10, range=(0, CREEK_LENGTH_M))[0].min() > 5
    assert any(o.material in ("timber", "grey_timber", "sign", "roof") for o in creek.objects)


def test_walks_span_the_path_at_two_speeds(creek):
    day = creek_drive(creek, "day", 272, DAY_LANE, 0)
    night = creek_drive(creek, "night", 315, NIGHT_LANE, 1)
    assert day.positions.shape == (272, 2) and night.positions.shape == (315, 2)
    for walk in (day, night):
        assert walk.positions[0, 0] < 10 and walk.positions[-1, 0] > CREEK_LENGTH_M - 10
        assert np.all(np.abs(walk.positions[:, 1]) < PATH_HALF_WIDTH)
        assert np.all(np.diff(walk.positions[:, 0]) > 0)  # always forwards
    day_step = np.diff(day.positions[:, 0]).mean()
    night_step = np.diff(night.positions[:, 0]).mean()
    assert day_step / night_step == pytest.approx(314 / 271, rel=0.01)  # another walking speed


def test_dataset_writes_positions_for_ground_truth(tmp_path):
    out = tmp_path / "creek"
    folders = make_creek_dataset(out, frames={"day_reference": 3, "night_query": 4})
    assert set(folders) == {"day_reference", "night_query"}
    for name, count in (("day_reference", 3), ("night_query", 4)):
        images = sorted((out / name / "images").iterdir())
        assert len(images) == count
        with open(out / name / "poses.csv", newline="") as stream:
            rows = list(csv.DictReader(stream))
        assert len(rows) == count and {"x", "y", "heading", "timestamp"} <= set(rows[0])
        # the walk's noisy odometry, what route mode predicts by (not the ground truth in poses.csv)
        traverse = load_traverse(out / name)
        odometry = route_odometry(traverse)
        assert odometry is not None and odometry.source == "odometry.csv"
        true_steps = np.hypot(*np.diff(traverse.positions, axis=0).T)
        assert not np.allclose(odometry.steps[1:], true_steps, rtol=1e-3)
        np.testing.assert_allclose(odometry.steps[1:], true_steps, rtol=0.25)
    description = json.loads((out / "dataset.json").read_text())
    assert description["traverses"]["night_query"] == {"condition": "night", "frames": 4, "lane_m": NIGHT_LANE}
    with pytest.raises(ValueError, match="frames must give"):
        make_creek_dataset(tmp_path / "bad", frames={"day_reference": 1, "night_query": 4})


def test_synth_command_refuses_panorama_options_for_the_creek(tmp_path, capsys):
    assert main(["synth", "--world", "creek", "--out", str(tmp_path / "c"), "--size", "96x48"]) == 2
    assert "forward camera" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()
