"""``nightloc localize`` against a map in its day drive's odometry frame (a teach run's), whose
errors are computed after the map's frame is aligned with the survey, and the TUM trajectory paired
with each pose's confidence."""

from __future__ import annotations

import csv
import re

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


def _fitted_errors(estimates: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Oracle: distances after the least-squares rotation and translation of ``estimates`` onto
    ``truth`` (Kabsch by SVD)."""
    a, b = estimates - estimates.mean(0), truth - truth.mean(0)
    u, _, vt = np.linalg.svd(a.T @ b)
    rotation = (u @ vt).T
    if np.linalg.det(rotation) < 0:
        rotation = (u @ np.diag([1.0, -1.0]) @ vt).T
    moved = a @ rotation.T + truth.mean(0)
    return np.hypot(*(moved - truth).T)


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
