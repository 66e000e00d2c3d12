"""A robot's recordings through the commands: ROS bags as traverses, the frames' times carried to
trajectory.csv, matches.csv and the TUM format, checked against independent readers."""

from __future__ import annotations

import csv
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

import nightloc
from nightloc.cli import main

from bag_support import NS, stamp_ns, write_bag
from synth_support import default_synth_data
from video_support import write_video

T0 = 1_712_345_678.0


def _rows(path):
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    return rows


def read_tum(path) -> np.ndarray:
    """An independent reader of the TUM trajectory format (the TUM RGB-D benchmark's definition):
    lines ``timestamp tx ty tz qx qy qz qw``, blank lines and ``#`` comments skipped; returns
    ``(N, 8)`` float64."""
    rows = []
    for line in Path(path).read_text(encoding="ascii").splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        fields = line.split()
        assert len(fields) == 8, line
        rows.append([float(f) for f in fields])
    return np.array(rows)


def _without_times(traverse: Path, copy: Path) -> Path:
    """A copy of a traverse folder with the timestamp column dropped from its CSV files."""
    shutil.copytree(traverse, copy)
    for name in ("poses.csv", "odometry.csv"):
        rows = [line.split(",") for line in (copy / name).read_text().splitlines()]
        keep = [k for k, column in enumerate(rows[0]) if column != "timestamp"]
        (copy / name).write_text("\n".join(",".join(row[k] for k in keep) for row in rows) + "\n")
    return copy


def _odom_frame(positions, headings, rotation=-1.1, shift=(12.0, 7.5)):
    """The drive as its own odometry reports it: in an odom frame turned and moved from the map's."""
    c, s = math.cos(rotation), math.sin(rotation)
    x = c * positions[:, 0] - s * positions[:, 1] + shift[0]
    y = s * positions[:, 0] + c * positions[:, 1] + shift[1]
    return np.column_stack([x, y, headings + rotation])


@pytest.fixture(scope="module")
def garden(tmp_path_factory):
    """The synthetic garden: its day map and its night drive as a folder and as a ROS 2 MCAP bag
    (bgr8 frames on /camera/image_raw, nav_msgs/Odometry on /odom in its own odom frame, stamped
    3 ms before each image)."""
    root = tmp_path_factory.mktemp("garden")
    folders = default_synth_data()["garden"]
    night = nightloc.load_traverse(folders["night_query"])
    frames = [night.read(i) for i in range(len(night))]
    frame_ns = [stamp_ns(T0 + 0.4 * i) + 123_457 for i in range(len(night))]
    odom_ns = [n - 3_000_000 for n in frame_ns]
    bag = write_bag(
        root / "night_bag",
        frames,
        frame_ns,
        storage="mcap",
        odometry=_odom_frame(night.positions, night.headings),
        odometry_ns=odom_ns,
    )
    map_file = root / "garden.map"
    assert main(["build-map", str(folders["day_reference"]), str(map_file)]) == 0
    return {"folders": folders, "night": night, "bag": bag, "frame_ns": frame_ns, "map": map_file, "root": root}


def test_a_ros2_mcap_bag_localizes_to_tum_without_naming_topics(garden, capsys):
    """A bag localized to TUM in one command: ``nightloc localize MAP BAG --out OUT --format tum``."""
    bag_out, folder_out = garden["root"] / "bag_run", garden["root"] / "folder_run"
    argv = ["localize", str(garden["map"]), str(garden["bag"]), "--out", str(bag_out), "--format", "tum"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "trajectory.tum" in printed
    assert main(["localize", str(garden["map"]), str(garden["folders"]["night_query"]), "--out", str(folder_out)]) == 0
    capsys.readouterr()
    tum = read_tum(bag_out / "trajectory.tum")
    night = garden["night"]
    assert tum.shape == (len(night), 8) and not (bag_out / "trajectory.csv").exists()
    # the times are the images' stamps
    expected = [float(f"{n // NS}.{n % NS:09d}") for n in garden["frame_ns"]]
    assert tum[:, 0].tolist() == expected
    # planar poses: z 0, a rotation about z only, unit quaternions
    np.testing.assert_array_equal(tum[:, [3, 4, 5]], 0.0)
    np.testing.assert_allclose(np.hypot(tum[:, 6], tum[:, 7]), 1.0, atol=1e-8)
    bag_errors = np.hypot(*(tum[:, 1:3] - night.positions).T)
    folder_rows = _rows(folder_out / "trajectory.csv")
    folder_xy = np.array([[float(r["x"]), float(r["y"])] for r in folder_rows])
    folder_errors = np.hypot(*(folder_xy - night.positions).T)
    assert abs(np.median(bag_errors) - np.median(folder_errors)) <= 0.1, (
        np.median(bag_errors),
        np.median(folder_errors),
    )
    assert np.median(bag_errors[9:]) < 0.6


def test_tum_yaw_is_the_heading_column(garden, capsys):
    out = garden["root"] / "both"
    argv = ["localize", str(garden["map"]), str(garden["bag"]), "--out", str(out), "--format", "csv,tum"]
    assert main([*argv, "--no-figures"]) == 0
    capsys.readouterr()
    tum = read_tum(out / "trajectory.tum")
    rows = _rows(out / "trajectory.csv")
    yaw = 2 * np.arctan2(tum[:, 6], tum[:, 7])
    heading = np.array([float(r["heading"]) for r in rows])
    turn = np.arctan2(np.sin(yaw - heading), np.cos(yaw - heading))
    assert np.abs(turn).max() < 1e-5  # the CSV's 5 decimals
    np.testing.assert_allclose(tum[:, 1:3], [[float(r["x"]), float(r["y"])] for r in rows], atol=1e-4)
    assert [float(r["timestamp"]) for r in rows] == tum[:, 0].tolist()
    assert [r["image"] for r in rows] == [f"frame_{i:06d}" for i in range(len(rows))]


def test_a_day_bag_with_a_pose_topic_builds_the_same_map_as_its_folder(garden, tmp_path, capsys):
    folders = garden["folders"]
    day = nightloc.load_traverse(folders["day_reference"])
    frame_ns = [stamp_ns(T0 + i) for i in range(len(day))]
    poses = np.column_stack([day.positions, day.headings])
    odom = _odom_frame(day.positions, day.headings)
    with_poses = write_bag(tmp_path / "day", [day.read(i) for i in range(len(day))], frame_ns, storage="sqlite3",
                           odometry=odom, poses=poses)  # fmt: skip
    assert main(["build-map", str(with_poses), str(tmp_path / "bag.map")]) == 0
    capsys.readouterr()
    from_bag = nightloc.ReferenceMap.load(tmp_path / "bag.map")
    from_folder = nightloc.ReferenceMap.load(garden["map"])
    np.testing.assert_array_equal(from_bag.images, from_folder.images)
    np.testing.assert_allclose(from_bag.positions, from_folder.positions, atol=1e-12)
    np.testing.assert_allclose(from_bag.headings, from_folder.headings, atol=1e-12)
    # without poses but with odometry: a teach run, as a folder with odometry.csv
    without = write_bag(tmp_path / "day_odometry", [day.read(i) for i in range(len(day))], frame_ns, odometry=odom)
    assert main(["build-map", str(without), str(tmp_path / "x.map")]) == 0
    printed = capsys.readouterr().out
    assert "teach run" in printed and "wheel odometry from the bag's /odom" in printed
    assert nightloc.ReferenceMap.load(tmp_path / "x.map").pose_source == "optimised"
    # without poses or odometry: the message a folder without either gives
    bare = write_bag(tmp_path / "day_bare", [day.read(i) for i in range(len(day))], frame_ns)
    assert main(["build-map", str(bare), str(tmp_path / "x2.map")]) == 2
    bag_error = capsys.readouterr().err
    without = bare
    folder = tmp_path / "day_folder"
    shutil.copytree(folders["day_reference"], folder)
    (folder / "poses.csv").unlink()
    (folder / "odometry.csv").unlink()
    assert main(["build-map", str(folder), str(tmp_path / "y.map")]) == 2
    folder_error = capsys.readouterr().err
    assert bag_error.replace(str(without), "X") == folder_error.replace(str(folder), "X")
    assert "nightloc route" in bag_error


def test_route_and_evaluate_take_bags_and_carry_the_times(garden, tmp_path, capsys):
    folders = garden["folders"]
    night = garden["night"]
    poses = np.column_stack([night.positions, night.headings])
    query = write_bag(tmp_path / "q.bag", [night.read(i) for i in range(len(night))], garden["frame_ns"],
                      storage="ros1", poses=poses)  # fmt: skip
    out = tmp_path / "route"
    argv = [
        "route",
        str(folders["day_reference"]),
        str(query),
        "--out",
        str(out),
        "--no-figures",
        "--camera",
        "panoramic",
    ]
    assert main(argv) == 0
    rows = _rows(out / "matches.csv")
    expected = [float(f"{n // NS}.{n % NS:09d}") for n in garden["frame_ns"]]
    assert [float(r["timestamp"]) for r in rows] == expected
    assert [r["query_image"] for r in rows][:2] == ["frame_000000", "frame_000001"]
    evaluated = tmp_path / "evaluate"
    argv = ["evaluate", str(garden["map"]), str(query), "--out", str(evaluated), "--seq-lengths", "1,7"]
    assert main([*argv, "--noise-models", "0", "--no-figures"]) == 0
    from_bag = _rows(evaluated / "errors.csv")
    argv = ["evaluate", str(garden["map"]), str(folders["night_query"]), "--out", str(tmp_path / "e2")]
    assert main([*argv, "--seq-lengths", "1,7", "--noise-models", "0", "--no-figures"]) == 0
    from_folder = _rows(tmp_path / "e2" / "errors.csv")
    assert [r["error_m"] for r in from_bag] == [r["error_m"] for r in from_folder]
    capsys.readouterr()


def test_bag_errors_on_the_command_line(garden, tmp_path, capsys):
    assert main(["localize", str(garden["map"]), str(garden["bag"]), "--out", str(tmp_path / "o"),
                 "--image-topic", "/nope"]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert "--image-topic /nope" in err and "/camera/image_raw" in err and "/odom" in err
    folders = garden["folders"]
    argv = ["localize", str(garden["map"]), str(folders["night_query"]), "--out", str(tmp_path / "o")]
    assert main([*argv, "--image-topic", "/camera"]) == 2
    assert "--image-topic applies to ROS bags" in capsys.readouterr().err
    untimed = _without_times(folders["night_query"], tmp_path / "untimed")
    assert main(["localize", str(garden["map"]), str(untimed), "--out", str(tmp_path / "o"), "--format", "tum"]) == 2
    err = capsys.readouterr().err
    assert "--format tum needs each frame's time" in err and "timestamp column" in err
    assert main(["localize", str(garden["map"]), str(untimed), "--out", str(tmp_path / "o"), "--format", "mcap"]) == 2
    err = capsys.readouterr().err
    assert "--format mcap needs each frame's time" in err and "timestamp column" in err
    assert not (tmp_path / "o").exists()  # nothing written
    assert main([*argv, "--format", "kml"]) == 2
    assert "--format" in capsys.readouterr().err
    # a bag as the map: it has no poses, but odometry: built by a teach run
    assert main(["localize", str(garden["bag"]), str(garden["bag"]), "--out", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "trajectory.csv").is_file()


def test_a_bag_whose_camera_starts_before_its_odometry_localizes_with_a_warning(garden, tmp_path, capsys):
    """The first frames come before the first odometry message: they are skipped, named with their
    times, and the others localize as the bag without them does."""
    night = garden["night"]
    frames = [night.read(i) for i in range(len(night))]
    frame_ns = garden["frame_ns"]
    odometry = _odom_frame(night.positions, night.headings)
    early = write_bag(tmp_path / "early", frames, frame_ns, odometry=odometry[3:], odometry_ns=frame_ns[3:])
    out = tmp_path / "early_run"
    assert main(["localize", str(garden["map"]), str(early), "--out", str(out), "--no-figures"]) == 0
    captured = capsys.readouterr()
    [warning] = captured.err.splitlines()
    times = [float(f"{n // NS}.{n % NS:09d}") for n in frame_ns[:3]]
    assert warning.startswith(f"nightloc localize: warning: bag {early}: 3 of {len(night)} frames of /camera/image_raw")
    assert "before the odometry /odom starts" in warning and ", ".join(f"{t:.3f}" for t in times) in warning
    rows = _rows(out / "trajectory.csv")
    assert [r["image"] for r in rows] == [f"frame_{i:06d}" for i in range(3, len(night))]
    # the oracle: a bag recorded from the fourth frame on
    trimmed = write_bag(tmp_path / "trimmed", frames[3:], frame_ns[3:], odometry=odometry[3:])
    assert main(["localize", str(garden["map"]), str(trimmed), "--out", str(tmp_path / "trimmed_run")]) == 0
    assert capsys.readouterr().err == ""
    expected = _rows(tmp_path / "trimmed_run" / "trajectory.csv")
    assert [(r["x"], r["y"], r["timestamp"]) for r in rows] == [(r["x"], r["y"], r["timestamp"]) for r in expected]


def test_a_folder_log_with_a_timestamp_column_carries_its_times(garden, tmp_path, capsys):
    night = garden["folders"]["night_query"]
    log = _without_times(night, tmp_path / "log")
    (log / "poses.csv").unlink()
    lines = (log / "odometry.csv").read_text().splitlines()
    times = [100.0 + 0.25 * k for k in range(len(lines) - 1)]
    (log / "odometry.csv").write_text(
        "\n".join([lines[0] + ",timestamp"] + [f"{line},{t!r}" for line, t in zip(lines[1:], times)]) + "\n"
    )
    traverse = nightloc.load_traverse(log)
    assert traverse.timestamps.tolist() == times
    assert nightloc.load_traverse(log, frame_step=2).timestamps.tolist() == times[::2]
    out = tmp_path / "out"
    assert main(["localize", str(garden["map"]), str(log), "--out", str(out), "--format", "csv,tum"]) == 0
    capsys.readouterr()
    assert [float(r["timestamp"]) for r in _rows(out / "trajectory.csv")] == times
    assert read_tum(out / "trajectory.tum")[:, 0].tolist() == times
    # a time that goes back is named with its line
    bad = (log / "odometry.csv").read_text().splitlines()
    bad[3] = bad[3].rsplit(",", 1)[0] + ",1.0"
    (log / "odometry.csv").write_text("\n".join(bad) + "\n")
    with pytest.raises(nightloc.DatasetError, match=r"odometry.csv line 4: timestamp 1.0 is before the previous"):
        nightloc.load_traverse(log)


def test_poses_csv_timestamps_and_video_frame_times(tmp_path):
    frames = [np.full((30, 60, 3), 40 * i, np.uint8) for i in range(4)]
    saved = nightloc.save_traverse(tmp_path / "t", frames, np.zeros((4, 2)), np.zeros(4))
    text = (saved.root / "poses.csv").read_text().splitlines()
    rows = [text[0] + ",timestamp"] + [f"{line},{5 + k * 0.5}" for k, line in enumerate(text[1:])]
    (saved.root / "poses.csv").write_text("\n".join(rows) + "\n")
    assert nightloc.load_traverse(saved.root).timestamps.tolist() == [5.0, 5.5, 6.0, 6.5]
    video = tmp_path / "v.avi"
    write_video(video, 6)  # 10 frames per second
    assert nightloc.load_traverse(video, frame_step=2).timestamps.tolist() == pytest.approx([0.0, 0.2, 0.4])


def test_a_bag_night_is_learned_with_its_frames_times(garden, tmp_path, capsys):
    """``localize MAP BAG --learn NEW``: the learned appearances keep their frames' bag stamps."""
    new_map = tmp_path / "night.map"
    argv = ["localize", str(garden["map"]), str(garden["bag"]), "--out", str(tmp_path / "run"), "--no-figures"]
    assert main([*argv, "--learn", str(new_map)]) == 0
    assert f"wrote {new_map}" in capsys.readouterr().out
    day, learned = nightloc.ReferenceMap.load(garden["map"]), nightloc.ReferenceMap.load(new_map)
    rec = learned.appearances
    assert rec is not None and rec.nights[0].source == str(garden["bag"])
    times = rec.time[len(day) :]
    assert len(times) > 0
    stamps = [n / NS for n in garden["frame_ns"]]
    assert all(min(abs(t - s) for s in stamps) < 1e-6 for t in times)
