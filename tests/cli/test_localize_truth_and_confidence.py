"""``nightloc localize`` against a map in its day drive's odometry frame (a teach run's), whose
errors are computed after the map's frame is aligned with the survey, and the TUM trajectory paired
with each pose's confidence."""

from __future__ import annotations

import csv
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.mapping import RigidTransform2D

from synth_support import default_synth_data

#: The day drive's odometry frame seen from the survey: its start turned and moved.
DRIVE = RigidTransform2D(0.9, (3.0, -2.0))


def _rows(path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def _printed_median(text: str) -> float:
    return float(re.search(r"median (\d+\.\d+) m", text).group(1))


def _fit(source: np.ndarray, target: np.ndarray):
    """Oracle: the least-squares rotation and translation of ``source`` onto ``target`` (Kabsch by
    SVD), as a function of ``(N, 2)`` points."""
    a, b = source - source.mean(0), target - target.mean(0)
    u, _, vt = np.linalg.svd(a.T @ b)
    rotation = (u @ vt).T
    if np.linalg.det(rotation) < 0:
        rotation = (u @ np.diag([1.0, -1.0]) @ vt).T
    return lambda points: (points - source.mean(0)) @ rotation.T + target.mean(0)


def _fitted_errors(estimates: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Oracle: distances after the best rigid fit of ``estimates`` onto ``truth``."""
    return np.hypot(*(_fit(estimates, truth)(estimates) - truth).T)


@pytest.fixture(scope="module")
def garden(tmp_path_factory):
    """The synthetic garden's surveyed map, and the same map in the day drive's odometry frame
    (what a teach run builds: pose source "optimised", its source the surveyed day folder)."""
    root = tmp_path_factory.mktemp("teach")
    folders = default_synth_data()["garden"]
    surveyed = nightloc.ReferenceMap.build(folders["day_reference"])
    drive_map = nightloc.ReferenceMap(
        surveyed.images,
        DRIVE.apply(surveyed.positions),
        DRIVE.apply_headings(surveyed.headings),
        surveyed.names,
        surveyed.params,
        str(folders["day_reference"]),
        surveyed.frame_size,
        pose_source="optimised",
    )
    return {
        "folders": folders,
        "root": root,
        "surveyed": surveyed.save(root / "surveyed.map"),
        "drive": drive_map.save(root / "drive.map"),
        "drive_map": drive_map,
        "night": nightloc.load_traverse(folders["night_query"]),
    }


def test_errors_against_a_map_in_the_drives_frame_are_those_of_a_rigid_fit(garden, capsys, monkeypatch):
    import nightloc.figures.trajectory as trajectory_module

    drawn = {}
    real = trajectory_module.trajectory_figure

    def spy(*args, **kwargs):
        drawn.update(truth=args[2], caption=kwargs["caption"])
        return real(*args, **kwargs)

    monkeypatch.setattr(trajectory_module, "trajectory_figure", spy)
    night, root = garden["night"], garden["root"]
    assert main(["localize", str(garden["drive"]), str(night.root), "--out", str(root / "drive_run")]) == 0
    printed = capsys.readouterr().out
    assert "rigid 2D fit of the map onto" in printed and "day_reference/poses.csv" in printed, printed
    rows = _rows(root / "drive_run" / "trajectory.csv")
    estimates = np.array([[float(r["x"]), float(r["y"])] for r in rows])  # in the drive's frame
    oracle = np.median(_fitted_errors(estimates, night.positions))
    reported = _printed_median(printed)
    assert abs(reported - oracle) <= 0.15, (reported, oracle)
    # the true path is drawn where the map is: in the drive's frame
    np.testing.assert_allclose(drawn["truth"], DRIVE.apply(night.positions), atol=1e-6)
    assert "rigid fit" in drawn["caption"]
    # the same night against the surveyed map errs as much
    assert main(["localize", str(garden["surveyed"]), str(night.root), "--out", str(root / "run"), "--no-figures"]) == 0
    surveyed = capsys.readouterr().out
    assert "rigid" not in surveyed
    assert abs(_printed_median(surveyed) - reported) <= 0.15, (surveyed, printed)


def test_without_a_survey_the_frames_are_said_to_differ_and_survey_names_one(garden, tmp_path, capsys):
    anonymous = garden["drive_map"]
    nameless = nightloc.ReferenceMap(
        anonymous.images,
        anonymous.positions,
        anonymous.headings,
        anonymous.names,
        anonymous.params,
        "",
        anonymous.frame_size,
        pose_source="optimised",
    ).save(tmp_path / "nameless.map")
    night = garden["night"]
    assert main(["localize", str(nameless), str(night.root), "--out", str(tmp_path / "a"), "--no-figures"]) == 0
    printed = capsys.readouterr().out
    assert "no distance errors" in printed and "--survey DAY" in printed and "median" not in printed, printed
    survey = garden["folders"]["day_reference"]
    argv = ["localize", str(nameless), str(night.root), "--out", str(tmp_path / "b"), "--no-figures"]
    assert main([*argv, "--survey", str(survey)]) == 0
    printed = capsys.readouterr().out
    assert "rigid 2D fit" in printed and "median" in printed
    # a survey that does not list the map's frames is an error before any work
    other = tmp_path / "other"
    shutil.copytree(survey, other)
    lines = (other / "poses.csv").read_text().splitlines()
    (other / "poses.csv").write_text("\n".join(lines[:11]) + "\n")  # 10 of the map's 24 frames
    argv = ["localize", str(nameless), str(night.root), "--out", str(tmp_path / "c"), "--survey", str(other)]
    assert main(argv) == 2
    assert "poses.csv" in capsys.readouterr().err and not (tmp_path / "c").exists()


@pytest.mark.slow
def test_a_teach_run_map_localizes_within_a_rigid_fit_of_the_truth(garden, tmp_path, capsys):
    """The real thing: a map from the day drive's wheel odometry alone (GTSAM). The printed errors
    are those of the night's truth moved into the map's frame by the fit of the map onto the day's
    survey (an independent fit here), far below the unaligned ones, and near those after the best
    rigid fit of the estimated path itself onto the truth (which absorbs part of the error)."""
    pytest.importorskip("gtsam")
    drive = tmp_path / "day"
    shutil.copytree(garden["folders"]["day_reference"], drive)
    survey = tmp_path / "survey"
    shutil.copytree(drive, survey)
    (drive / "poses.csv").unlink()
    assert main(["build-map", str(drive), str(tmp_path / "teach.map")]) == 0
    capsys.readouterr()
    night = garden["night"]
    out = tmp_path / "run"
    argv = ["localize", str(tmp_path / "teach.map"), str(night.root), "--out", str(out), "--no-figures"]
    assert main([*argv, "--survey", str(survey)]) == 0
    printed = capsys.readouterr().out
    estimates = np.array([[float(r["x"]), float(r["y"])] for r in _rows(out / "trajectory.csv")])
    teach = nightloc.ReferenceMap.load(tmp_path / "teach.map")
    surveyed = nightloc.load_traverse(survey)
    day = dict(zip(surveyed.names, surveyed.positions))
    to_map = _fit(np.array([day[name] for name in teach.names]), teach.positions)
    aligned = np.median(np.hypot(*(estimates - to_map(night.positions)).T))
    assert abs(_printed_median(printed) - aligned) <= 0.006, (printed, aligned)
    unaligned = np.median(np.hypot(*(estimates - night.positions).T))
    assert aligned < 0.6 * unaligned, (aligned, unaligned)
    assert aligned - np.median(_fitted_errors(estimates, night.positions)) <= 0.2


def test_the_tum_trajectory_comes_with_each_poses_confidence(garden, tmp_path, capsys):
    night = garden["night"]
    out = tmp_path / "all"
    argv = ["localize", str(garden["surveyed"]), str(night.root), "--no-figures"]
    assert main([*argv, "--out", str(out), "--format", "csv,tum"]) == 0
    capsys.readouterr()
    tum_lines = (out / "trajectory.tum").read_text().splitlines()
    with open(out / "trajectory_confidence.csv", newline="") as handle:
        header, *paired = list(csv.reader(handle))
    assert header == ["timestamp", "confidence", "credible_radius"]
    assert [row[0] for row in paired] == [line.split()[0] for line in tum_lines]  # the same times, as written
    frames = _rows(out / "trajectory.csv")
    assert [(r["confidence"], r["credible_radius"]) for r in frames] == [(c, r) for _, c, r in paired]
    assert [float(r["timestamp"]) for r in frames] == night.timestamps.tolist()
    # only the confident frames: the TUM file and its pairing shrink together, trajectory.csv keeps all
    confident = [r["timestamp"] for r in frames if float(r["confidence"]) >= 0.5]
    assert 0 < len(confident) < len(frames) and float(frames[0]["confidence"]) < 0.5  # the cold start is out
    trimmed = tmp_path / "confident"
    assert main([*argv, "--out", str(trimmed), "--format", "csv,tum", "--min-confidence", "0.5"]) == 0
    assert f"trajectory.tum: {len(confident)} of {len(frames)} frames" in capsys.readouterr().out
    tum = [line.split()[0] for line in (trimmed / "trajectory.tum").read_text().splitlines()]
    assert [float(t) for t in tum] == [float(t) for t in confident]
    assert [row["timestamp"] for row in _rows(trimmed / "trajectory_confidence.csv")] == tum
    assert len(_rows(trimmed / "trajectory.csv")) == len(frames)
    assert main([*argv, "--out", str(tmp_path / "bad"), "--min-confidence", "1.5"]) == 2
    assert "--min-confidence must be in [0, 1]" in capsys.readouterr().err
    assert main([*argv, "--out", str(tmp_path / "csv"), "--min-confidence", "0.5"]) == 2
    assert "--min-confidence applies to --format tum" in capsys.readouterr().err


def test_readme_names_the_confidence_file():
    readme = (Path(__file__).parents[2] / "README.md").read_text()
    assert "trajectory_confidence.csv" in readme and "--min-confidence" in readme
