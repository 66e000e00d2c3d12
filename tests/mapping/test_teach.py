"""The teach run end to end on the synthetic world, and its bad inputs."""

from __future__ import annotations

import shutil
import sys
import warnings

import numpy as np
import pytest

pytest.importorskip("gtsam")

import nightloc
from nightloc import DatasetError, ReferenceMap
from nightloc.errors import MappingError, MissingDependencyError
from nightloc.localization.evaluation import (
    EvaluationSettings,
    align_to_map,
    evaluate,
    map_alignment,
    match_traverse,
)
from nightloc.mapping import TeachParams, TeachWarning, absolute_trajectory_error, teach_run
from nightloc.motion.wheel_noise import WheelNoise
from nightloc.synth import make_dataset

from preparation_oracle import panorama
from synth_support import default_synth_data


@pytest.fixture(scope="module")
def garden():
    return default_synth_data()["garden"]


@pytest.fixture(scope="module")
def taught(garden):
    with warnings.catch_warnings():
        warnings.simplefilter("error", TeachWarning)  # the garden's images overlap: no warning
        return teach_run(garden["day_reference"])


def test_teach_run_beats_dead_reckoning(garden, taught):
    teach_map, report = taught
    truth = nightloc.load_traverse(garden["day_reference"]).positions
    reckoned = absolute_trajectory_error(report.dead_reckoning[:, :2], truth)
    optimised = absolute_trajectory_error(teach_map.positions, truth)
    assert teach_map.pose_source == "optimised" and report.pose_source == "optimised"
    assert optimised < 0.75 * reckoned and optimised < 0.3
    assert report.accepted >= 20 and report.accepted > 5 * report.rejected
    np.testing.assert_allclose(teach_map.positions[0], [0.0, 0.0], atol=1e-6)  # the odometry frame
    assert teach_map.headings[0] == pytest.approx(0.0, abs=1e-6)
    variances = np.linalg.eigvalsh(teach_map.covariances)
    assert (variances > -1e-12).all() and variances[1:, -1].min() > 0  # frame 0 is the fixed origin


def test_map_file_and_api_agree(garden, taught, tmp_path):
    teach_map, _ = taught
    loaded = ReferenceMap.load(teach_map.save(tmp_path / "teach.map"))
    assert loaded == teach_map and loaded.pose_source == "optimised"
    # ReferenceMap.build runs the same teach run for a traverse without poses
    day = tmp_path / "day"
    shutil.copytree(garden["day_reference"], day)
    (day / "poses.csv").unlink()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TeachWarning)
        built = ReferenceMap.build(day)
    np.testing.assert_allclose(built.positions, teach_map.positions, atol=1e-9)
    assert built.pose_source == "optimised"


def test_night_localization_on_the_taught_map(garden, taught):
    """Teach -> localize: the Bayes filter on the night drive errs about as much on the taught
    map (its truth moved into the map frame by the rigid fit) as on the surveyed one."""
    teach_map, _ = taught
    surveyed = ReferenceMap.build(garden["day_reference"])
    settings = EvaluationSettings(
        seq_lengths=(1,), noise_models=(1,), interpolation=(True,), odometry="robot", methods=("filter",)
    )
    transform, text = map_alignment(teach_map)
    assert "rigid 2D fit" in text and map_alignment(surveyed) is None
    errors = {}
    for name, ref_map in (("surveyed", surveyed), ("taught", teach_map)):
        matches = match_traverse(ref_map, garden["night_query"], tables=True)
        if ref_map is teach_map:
            matches = align_to_map(matches, transform)
        evaluation = evaluate(ref_map, matches, settings)
        errors[name] = float(np.median(evaluation.errors(method="filter")[9:]))
    assert errors["taught"] <= 1.5 * errors["surveyed"] + 0.1, errors


# --- bad input


@pytest.fixture
def small_drive(tmp_path, garden):
    day = tmp_path / "drive"
    shutil.copytree(garden["day_reference"], day)
    (day / "poses.csv").unlink()
    return day


def _odometry_lines(day):
    return (day / "odometry.csv").read_text().splitlines()


def test_missing_odometry_row(small_drive):
    lines = _odometry_lines(small_drive)
    (small_drive / "odometry.csv").write_text("\n".join(lines[:5] + lines[6:]) + "\n")
    with pytest.raises(DatasetError, match=r"no row for image '000004\.png'"):
        teach_run(small_drive)


def test_non_finite_odometry(small_drive):
    lines = _odometry_lines(small_drive)
    cells = lines[3].split(",")
    cells[lines[0].split(",").index("turn")] = "nan"
    lines[3] = ",".join(cells)
    (small_drive / "odometry.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(DatasetError, match="line 4: column 'turn' is 'nan'; odometry must be finite"):
        teach_run(small_drive)


def test_map_frame_odometry_is_refused(small_drive):
    names = [line.split(",")[0] for line in _odometry_lines(small_drive)[1:]]
    (small_drive / "odometry.csv").write_text("image,dx,dy\n" + "".join(f"{n},0.5,0\n" for n in names))
    with pytest.raises(MappingError, match="needs wheel odometry"):
        teach_run(small_drive)


def test_images_that_never_overlap_give_dead_reckoning_with_a_warning(tmp_path):
    """Frames 3 m apart (beyond the distance gate) of unrelated scenes (no strong match)."""
    frames = [panorama(96, 192, seed=s) for s in range(8)]
    positions = np.column_stack([np.arange(8) * 3.0, np.zeros(8)])
    day = nightloc.save_traverse(tmp_path / "noise", frames, positions, np.zeros(8))
    odometry = [None] + [nightloc.RobotMotion(3.0, 0.0, 0.0)] * 7
    with pytest.warns(TeachWarning, match="dead reckoning"):
        teach_map, report = teach_run(day, odometry=odometry, teach=TeachParams(strong_score=5.0))
    assert teach_map.pose_source == "dead-reckoned" and report.accepted == 0
    np.testing.assert_allclose(teach_map.positions, positions, atol=1e-9)
    assert teach_map.covariances[-1, 0, 0] > teach_map.covariances[1, 0, 0] > 0


def test_unsolvable_graph_is_one_error(small_drive, monkeypatch):
    import gtsam

    from nightloc.mapping import optimiser

    monkeypatch.setattr(optimiser, "build_graph", lambda *args, **kwargs: gtsam.NonlinearFactorGraph())
    with pytest.raises(MappingError, match="could not be solved"):
        teach_run(small_drive)


def test_without_gtsam_one_error_names_the_install(small_drive, monkeypatch):
    monkeypatch.setitem(sys.modules, "gtsam", None)
    with pytest.raises(MissingDependencyError, match=r'pip install "nightloc\[mapping\]"'):
        teach_run(small_drive)


def test_large_garden_plans():
    """The large garden's drives: a perimeter pass then mowing rows, images 0.5 m apart, a night
    drive across; every camera position is free of the world's solids."""
    from nightloc.synth import plan_traverses
    from nightloc.synth.world import build_world

    day, night = plan_traverses("large_garden")
    steps = np.hypot(*np.diff(day.positions, axis=0).T)
    assert 800 < len(day.positions) < 1000 and 0.4 < np.median(steps) < 0.6 and steps.max() < 0.75
    assert day.positions.min(axis=0) == pytest.approx([0.5, 0.5], abs=0.15)
    assert day.positions.max(axis=0) == pytest.approx([24.5, 14.5], abs=0.15)
    assert len(night.positions) > 80
    world = build_world("large_garden")
    for plan in (day, night):
        world.check_camera_positions(plan.positions)


@pytest.mark.slow
def test_large_garden_renders(tmp_path):
    """A few frames of the large garden at a small size (its whole render is slow)."""
    from nightloc.synth import Camera

    folders = make_dataset("large_garden", tmp_path / "lg", camera=Camera(48, 24))
    day = nightloc.load_traverse(folders["day_reference"])
    assert len(day) > 800 and (folders["day_reference"] / "odometry.csv").is_file()


def test_teach_params_from_toml(tmp_path):
    """TeachParams is the [teach] table: saved and loaded whole, beside other tables; its odometry
    model and camera elevations checked like the classes they build."""
    params = TeachParams(rounds=2, heading_method="warp", odometry_turn_bias_std=0.02, elevation_top_deg=40.0)
    path = tmp_path / "params.toml"
    nightloc.save_params(path, [nightloc.PreparationParams(), params])
    assert "[teach]" in path.read_text()
    loaded = nightloc.load_params(path, TeachParams)
    assert loaded == params and loaded.wheel_noise.turn_bias_std == 0.02 and loaded.warp.elevation_top == 40.0
    assert nightloc.load_params(path, nightloc.PreparationParams) == nightloc.PreparationParams()
    for bad, words in (
        ({"rounds": 0}, "rounds"),
        ({"odometry_scale_std": 0.6}, "odometry"),
        ({"elevation_top_deg": -40.0}, "elevation"),
        ({"max_distance": 0.0}, "max_distance"),
        ({"heading_method": "columns"}, "heading_method"),
    ):
        with pytest.raises((ValueError, TypeError), match=words):
            TeachParams(**bad)
    noise = WheelNoise(scale_std=0.01, turn_std=0.02)
    assert TeachParams.with_wheel_noise(noise, rounds=3).wheel_noise == noise
