"""Columns of poses.csv and odometry.csv: other columns are ignored, but a near miss of a column
nightloc reads (``haeding`` for ``heading``) is refused, naming the column it resembles, instead of
being ignored as another column."""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.errors import DatasetError
from nightloc.io.odometry_csv import read_odometry_rows
from nightloc.io.poses import _edit_distance, read_pose_csv

from reliability_support import random_frames


def _poses(tmp_path, header: str, name: str = "poses.csv"):
    cells = len(header.split(","))
    rows = [f"{k:06d}.png," + ",".join(["0.5"] * (cells - 1)) for k in range(3)]
    path = tmp_path / name
    path.write_text("\n".join([header, *rows]) + "\n")
    return path


@pytest.mark.parametrize(
    ("a", "b", "distance"),
    [("heading", "heading", 0), ("haeding", "heading", 1), ("heding", "heading", 1), ("headings", "heading", 1),
     ("timestmap", "timestamp", 1), ("time_stamp", "timestamp", 1), ("trun", "turn", 1), ("x", "z", 1),
     ("frame", "image", 3), ("", "left", 4), ("ab", "ba", 1), ("abc", "ca", 3)],
)  # fmt: skip
def test_edit_distance_counts_insertions_deletions_substitutions_and_swaps(a, b, distance):
    assert _edit_distance(a, b) == distance
    assert _edit_distance(b, a) == distance


@pytest.mark.parametrize(
    ("header", "meant"),
    [
        ("image,x,y,haeding", "heading"),
        ("image,x,y,Heding", "heading"),
        ("image,x,y,heading,timestmap", "timestamp"),
        ("imgae,x,y,heading", "image"),
        ("image,x,y,headings", "heading"),
    ],
)
def test_a_misspelt_pose_column_is_refused_naming_the_column_it_resembles(tmp_path, header, meant):
    path = _poses(tmp_path, header)
    with pytest.raises(DatasetError, match=rf"did you mean '{meant}'\?") as caught:
        read_pose_csv(path, "image")
    message = str(caught.value)
    assert f"{path} line 1" in message and "image,x,y[,heading][,timestamp]" in message, message


@pytest.mark.parametrize(
    "header", ["image,x,y,heading,z,qx,qy,qz,qw", "image,x,y,note,speed,covariance", "image,x,y,heading,yaw,hdg"]
)
def test_other_pose_columns_are_still_ignored(tmp_path, header):
    rows, has_heading = read_pose_csv(_poses(tmp_path, header), "image")
    assert len(rows) == 3 and has_heading == ("heading" in header.split(","))


@pytest.mark.parametrize(
    ("header", "meant"),
    [
        ("image,forward,left,trun", "turn"),
        ("image,foward,left,turn", "forward"),
        ("image,forward,left,turn,timestamps", "timestamp"),
        ("image,dx,dy,timestmp", "timestamp"),
    ],
)
def test_a_misspelt_odometry_column_is_refused(tmp_path, header, meant):
    path = _poses(tmp_path, header, "odometry.csv")
    with pytest.raises(DatasetError, match=rf"line 1: column .* did you mean '{meant}'\?"):
        read_odometry_rows(path)


def test_other_odometry_columns_are_still_ignored(tmp_path):
    rows, form = read_odometry_rows(_poses(tmp_path, "image,forward,left,turn,heading,dz,velocity", "odometry.csv"))
    assert form == "robot" and rows[0][1] == (0.5, 0.5, 0.5)
    rows, form = read_odometry_rows(_poses(tmp_path, "image,dx,dy,dz,left_wheel", "odometry.csv"))
    assert form == "map" and rows[0][1] == (0.5, 0.5)


def test_build_map_refuses_a_poses_csv_with_haeding(tmp_path, capsys):
    """The typo used to make a map without headings, and the failure surfaced later, in localize."""
    frames = random_frames(4)
    positions = np.column_stack([np.arange(4.0), np.zeros(4)])
    day = nightloc.save_traverse(tmp_path / "day", frames, positions, np.zeros(4)).root
    poses = day / "poses.csv"
    poses.write_text(poses.read_text().replace("heading", "haeding", 1))
    assert main(["build-map", str(day), str(tmp_path / "day.map")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'haeding'" in err and "did you mean 'heading'?" in err, err
    assert not (tmp_path / "day.map").exists()
