"""What a new user meets first: paths given in the wrong place, cameras, and errors that say what
to do next, each through the command line as a user types it."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.mapping.reference_map import ReferenceMap

from reliability_support import FRAMES, Workspace, random_frames


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    workspace = Workspace(tmp_path_factory.mktemp("front"))
    motions = [None] + [nightloc.RobotMotion(0.5, 0.0, 0.1)] * (FRAMES - 1)
    workspace.log = nightloc.save_traverse(
        workspace.root / "log", workspace.frames, workspace.positions, workspace.headings, odometry=motions
    ).root
    # forward-camera frames (4:3) of the same places, and their map
    workspace.forward_frames = random_frames(FRAMES, seed=3, shape=(48, 64, 3))
    workspace.forward = nightloc.save_traverse(
        workspace.root / "forward", workspace.forward_frames, workspace.positions, workspace.headings, odometry=motions
    ).root
    return workspace


def _error(capsys, argv) -> str:
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# --------------------------------------------------------------------------------------------
# paths in the wrong place are named for what they are


@pytest.mark.parametrize(
    ("case", "words"),
    [
        ("localize LOG MAP", ["LOG", "reference map", "the map comes first"]),
        ("route MAP TRAVERSE", ["REFERENCE", "reference map", "two traverses"]),
        ("route TRAVERSE MAP", ["QUERY", "reference map"]),
        ("evaluate TRAVERSE MAP", ["QUERY", "reference map", "reference comes first"]),
        ("build-map MAP OUT", ["reference map", "not a traverse", "order of the arguments"]),
        ("build-map TEXT OUT", ["a text file", "not a traverse"]),
        ("build-map CSV OUT", ["single file"]),
        ("localize MAP FOLDER-WITHOUT-IMAGES", ["not a traverse", "no 'images/' folder"]),
        ("evaluate TEXT TRAVERSE", ["not a nightloc reference map", "a text file"]),
    ],
)
def test_swapped_and_wrong_kind_paths_are_named_for_what_they_are(ws, capsys, tmp_path, case, words):
    empty = tmp_path / "empty"
    empty.mkdir()
    (tmp_path / "poses.csv").write_text("image,x,y\n")
    argv = {
        "localize LOG MAP": ["localize", ws.log, ws.map_file, "--out", tmp_path / "o"],
        "route MAP TRAVERSE": ["route", ws.map_file, ws.log, "--out", tmp_path / "o"],
        "route TRAVERSE MAP": ["route", ws.log, ws.map_file, "--out", tmp_path / "o"],
        "evaluate TRAVERSE MAP": ["evaluate", ws.log, ws.map_file, "--out", tmp_path / "o"],
        "build-map MAP OUT": ["build-map", ws.map_file, tmp_path / "x.map"],
        "build-map TEXT OUT": ["build-map", ws.text_file, tmp_path / "x.map"],
        "build-map CSV OUT": ["build-map", tmp_path / "poses.csv", tmp_path / "x.map"],
        "localize MAP FOLDER-WITHOUT-IMAGES": ["localize", ws.map_file, empty, "--out", tmp_path / "o"],
        "evaluate TEXT TRAVERSE": ["evaluate", ws.text_file, ws.log, "--out", tmp_path / "o"],
    }[case]
    err = _error(capsys, argv)
    for word in words:
        assert word in err, err
    assert "codec" not in err and "video" not in err.split("error:")[1].split("(")[0], err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_a_broken_file_with_a_video_suffix_still_says_video(ws, capsys, tmp_path):
    junk = tmp_path / "drive.mp4"
    junk.write_bytes(b"not a video at all")
    err = _error(capsys, ["build-map", junk, tmp_path / "x.map"])
    assert "video" in err and "cannot be opened" in err


# --------------------------------------------------------------------------------------------
# cameras


def test_build_map_camera_forward_builds_a_forward_map_and_stores_the_camera(ws, capsys, tmp_path):
    target = tmp_path / "forward.map"
    assert main(["build-map", str(ws.forward), str(target), "--camera", "forward"]) == 0
    assert "camera forward" in capsys.readouterr().out
    built = ReferenceMap.load(target)
    assert built.camera == "forward" and built.params.wrap is False and built.params.shifts == [0]
    assert built.frame_size == (64, 48)
    with np.load(target) as archive:
        header = json.loads(archive["header"].tobytes())
    assert header["camera"] == "forward" and header["frame_size"] == [64, 48]


def test_frames_too_narrow_for_a_panorama_are_never_prepared_as_one(ws, capsys, tmp_path):
    # nothing says which camera: the default (panoramic) does not fit 4:3 frames, so the fix is named
    err = _error(capsys, ["build-map", ws.forward, tmp_path / "p.map"])
    assert "64x48" in err and "nothing says which camera" in err and "--camera forward" in err, err
    # a panoramic camera named for them is refused too; so is a reference traverse prepared so
    err = _error(capsys, ["build-map", ws.forward, tmp_path / "p.map", "--camera", "panoramic"])
    assert "--camera panoramic says they are 360-degree panoramas" in err and "--camera forward" in err, err
    err = _error(capsys, ["localize", ws.forward, ws.forward, "--out", tmp_path / "o"])
    assert "nothing says which camera" in err, err
    assert not (tmp_path / "p.map").exists() and not (tmp_path / "o").exists()


def _synth_described(root, traverse, description: dict):
    """A copy of ``traverse`` in ``root/<name>`` beside a ``dataset.json`` as nightloc synth writes it."""
    root.mkdir()
    shutil.copytree(traverse, root / "day_reference")
    body = {"generator": "nightloc.synth", "traverses": {"day_reference": {"condition": "day"}}, **description}
    (root / "dataset.json").write_text(json.dumps(body))
    return root / "day_reference"


@pytest.mark.parametrize("description", [{"view": "forward"}, {"camera": {"view": "forward", "width": 64}}])
def test_build_map_takes_the_camera_that_the_dataset_records(ws, capsys, tmp_path, description):
    day = _synth_described(tmp_path / "fwd", ws.forward, description)
    assert main(["build-map", str(day), str(tmp_path / "f.map")]) == 0
    assert f"camera forward (as {tmp_path / 'fwd' / 'dataset.json'} says)" in capsys.readouterr().out
    assert ReferenceMap.load(tmp_path / "f.map").camera == "forward"
    # an option that contradicts the record names both; one that agrees is accepted
    err = _error(capsys, ["build-map", day, tmp_path / "p.map", "--camera", "panoramic"])
    assert "--camera panoramic contradicts" in err and "dataset.json" in err and "records a forward camera" in err
    params = tmp_path / "prep.toml"
    params.write_text("[preparation]\nwrap = true\n")
    err = _error(capsys, ["build-map", day, tmp_path / "p.map", "--params", params])
    assert "wrap = true" in err and "records a forward camera" in err, err
    assert main(["build-map", str(day), str(tmp_path / "g.map"), "--camera", "forward"]) == 0
    # a description by another tool, or one not listing the traverse, records nothing
    (tmp_path / "fwd" / "dataset.json").write_text(json.dumps({"view": "forward", "traverses": ["day_reference"]}))
    assert "nothing says which camera" in _error(capsys, ["build-map", day, tmp_path / "p.map"])


def test_a_camera_option_against_a_map_of_another_camera_is_named_as_the_cause(ws, capsys, tmp_path):
    target = tmp_path / "f.map"
    assert main(["build-map", str(ws.forward), str(target), "--camera", "forward"]) == 0
    err = _error(capsys, ["localize", target, ws.forward, "--out", tmp_path / "o", "--camera", "panoramic"])
    assert err.split("error: ")[1].startswith("--camera panoramic says that the log"), err
    assert "drop --camera panoramic" in err and "forward camera's" in err, err


def test_camera_and_a_parameter_file_that_contradict_each_other_are_refused(ws, capsys, tmp_path):
    params = tmp_path / "prep.toml"
    params.write_text("[preparation]\nwrap = true\n")
    err = _error(capsys, ["build-map", ws.forward, tmp_path / "x.map", "--camera", "forward", "--params", params])
    assert "--camera forward" in err and "wrap = true" in err
    params.write_text("[preparation]\nequalize = 'clahe'\n")  # no wrap: the camera decides
    assert (
        main(["build-map", str(ws.forward), str(tmp_path / "y.map"), "--camera", "forward", "--params", str(params)])
        == 0
    )
    built = ReferenceMap.load(tmp_path / "y.map")
    assert built.camera == "forward" and built.params.equalize == "clahe"


def test_frames_of_another_camera_are_refused_naming_both(ws, capsys, tmp_path):
    # a forward camera's log (4:3) against the panoramic map (2:1): refused, not localized silently
    err = _error(capsys, ["localize", ws.map_file, ws.forward, "--out", tmp_path / "o"])
    assert "64x48" in err and "60x30" in err and "forward" in err and "panoramic" in err, err
    err = _error(capsys, ["evaluate", ws.map_file, ws.forward, "--out", tmp_path / "o", "--seq-lengths", "1"])
    assert "forward" in err and "panoramic" in err, err
    err = _error(capsys, ["route", ws.log, ws.forward, "--out", tmp_path / "o", "--ground-truth", "none"])
    assert "64x48" in err and "60x30" in err, err
    # a camera named on the command line must be the map's
    err = _error(capsys, ["localize", ws.map_file, ws.log, "--out", tmp_path / "o", "--camera", "forward"])
    assert "forward camera" in err and "panoramic camera" in err, err
    # frames of the map's shape at another size are refused too, naming both sizes and the fix
    bigger = nightloc.save_traverse(
        tmp_path / "bigger",
        [np.kron(frame, np.ones((2, 2, 1), np.uint8)) for frame in ws.frames],
        ws.positions,
        ws.headings,
        odometry=[None] * FRAMES,
    )
    for command in (["localize"], ["evaluate", "--seq-lengths", "1"]):
        err = _error(capsys, [command[0], ws.map_file, bigger.root, "--out", tmp_path / "b", *command[1:]])
        assert "has 120x60 frames" in err and "built from 60x30 frames" in err, err
        assert "resize the frames to 60x30" in err and "build a map from 120x60 frames" in err, err
    assert not (tmp_path / "b").exists()
    with pytest.raises(ValueError, match=r"120x60 frames.*60x30 frames"):
        ws.map.check_frames(bigger.read(0).shape, "the log")
    # a reference traverse is prepared for the log's frames, and route mode needs only their shape
    assert main(["localize", str(bigger.root), str(bigger.root), "--out", str(tmp_path / "b"), "--no-figures"]) == 0
    assert main(["route", str(ws.log), str(bigger.root), "--out", str(tmp_path / "r"), "--no-figures"]) == 0


def test_a_forward_map_localizes_forward_frames_and_route_takes_the_camera(ws, capsys, tmp_path):
    target = tmp_path / "f.map"
    assert main(["build-map", str(ws.forward), str(target), "--camera", "forward"]) == 0
    out = tmp_path / "o"
    argv = ["localize", str(target), str(ws.forward), "--out", str(out), "--no-figures", "--camera", "forward"]
    argv += ["--odometry", "none"]  # wheel odometry needs headings from the match, which shift 0 does not give
    assert main(argv) == 0
    capsys.readouterr()
    assert main(["route", str(ws.log), str(ws.log), "--out", str(tmp_path / "r"), "--camera", "panoramic"]) == 0
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["method_params"]["circular_shifts"] is True and summary["preparation"]["wrap"] is True


def test_a_map_without_its_frame_size_is_still_read(ws, tmp_path):
    """Maps written before the camera was recorded load, and are not checked by frame shape."""
    older = ws.map_variant(header_changes={"frame_size": None})
    with np.load(older) as archive:
        members = {name: archive[name] for name in archive.files}
    header = json.loads(members["header"].tobytes())
    del header["frame_size"], header["camera"]
    members["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    with open(older, "wb") as stream:
        np.savez(stream, **members)
    loaded = ReferenceMap.load(older)
    assert loaded.frame_size is None and loaded.camera == "panoramic"
    loaded.check_frames((480, 640, 3), "a log")  # nothing to compare with: accepted
    with pytest.raises(ValueError, match="forward camera"):
        loaded.check_frames((480, 640, 3), "a log", camera="forward")


# --------------------------------------------------------------------------------------------
# errors that say what to do next


def test_a_log_without_odometry_csv_is_told_about_odometry_none(ws, capsys, tmp_path):
    log = tmp_path / "log"
    shutil.copytree(ws.log, log)
    (log / "odometry.csv").unlink()
    err = _error(capsys, ["localize", ws.map_file, log, "--out", tmp_path / "o"])
    assert "odometry.csv" in err and "--odometry none" in err
    assert main(["localize", str(ws.map_file), str(log), "--out", str(tmp_path / "o"), "--odometry", "none"]) == 0


def test_build_map_without_poses_points_to_route_mode_and_the_teach_run(ws, capsys, tmp_path):
    no_poses = ws.traverse_variant(remove=["poses.csv"])
    err = _error(capsys, ["build-map", no_poses, tmp_path / "x.map"])
    assert "no poses" in err and "poses.csv" in err and "nightloc route" in err and "teach run" in err


def test_command_line_errors_speak_in_options_not_api_arguments(ws, capsys, tmp_path):
    existing = tmp_path / "exists.map"
    shutil.copy(ws.map_file, existing)
    err = _error(capsys, ["build-map", ws.traverse.root, existing])
    assert "--overwrite" in err and "overwrite=True" not in err
    params = tmp_path / "clahe.toml"
    params.write_text("[preparation]\nequalize = 'clahe'\n")
    err = _error(capsys, ["localize", ws.map_file, ws.log, "--out", tmp_path / "o", "--params", params])
    assert "--params" in err and "without params" not in err, err
    err = _error(capsys, ["build-map", ws.traverse.root, tmp_path / "y.map", "--frame-step", "0"])
    assert "--frame-step" in err and "frame_step" not in err
    err = _error(capsys, ["route", ws.log, ws.log, "--out", tmp_path / "o", "--vmin", "2", "--vmax", "1"])
    assert "--vmin" in err and "--vmax" in err
    # the API keeps its own words
    with pytest.raises(FileExistsError, match=r"overwrite=True"):
        nightloc.ReferenceMap.load(ws.map_file).save(existing)
    with pytest.raises(nightloc.MapFormatError, match="without params"):
        nightloc.ReferenceMap.load(ws.map_file, nightloc.PreparationParams(equalize="clahe"))


@pytest.mark.parametrize("file", ["poses.csv", "odometry.csv"])
def test_a_semicolon_csv_is_told_to_use_commas(ws, tmp_path, file):
    log = tmp_path / "log"
    shutil.copytree(ws.log, log)
    text = (log / file).read_text()
    (log / file).write_text(text.replace(",", ";"))
    expected = r"line 1: the columns are separated by semicolons.*commas"
    if file == "poses.csv":
        with pytest.raises(nightloc.DatasetError, match=expected):
            nightloc.load_traverse(log)
    else:
        traverse = nightloc.load_traverse(log)
        with pytest.raises(nightloc.DatasetError, match=expected):
            nightloc.traverse_odometry(traverse)


def test_headings_and_turns_in_degrees_are_refused(ws, tmp_path, capsys):
    degrees = ws.pose_rows().splitlines()
    header, first, *rest = degrees
    name, x, y, _ = first.split(",")
    variant = ws.traverse_variant(csv="\n".join([header, f"{name},{x},{y},90.0", *rest]) + "\n")
    with pytest.raises(nightloc.DatasetError, match=r"poses.csv line 2: column 'heading' is 90.*radians.*degrees"):
        nightloc.load_traverse(variant)
    err = _error(capsys, ["build-map", variant, tmp_path / "x.map"])
    assert "line 2" in err and "degrees" in err
    # a full turn either way is still an angle in radians
    ok = ws.traverse_variant(csv="\n".join([header, f"{name},{x},{y},{-2 * math.pi}", *rest]) + "\n")
    assert nightloc.load_traverse(ok).headings[0] == pytest.approx(0.0, abs=1e-12)
    log = tmp_path / "log"
    shutil.copytree(ws.log, log)
    rows = (log / "odometry.csv").read_text().splitlines()
    rows[2] = rows[2].rsplit(",", 1)[0] + ",45"
    (log / "odometry.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(nightloc.DatasetError, match=r"odometry.csv line 3: column 'turn' is 45"):
        nightloc.traverse_odometry(nightloc.load_traverse(log))


# --------------------------------------------------------------------------------------------
# smaller findings


def test_short_steps_print_in_milliseconds(ws, capsys, tmp_path):
    from nightloc.commands.wording import duration

    assert duration(0.0034) == "3.4 ms" and duration(0.25) == "0.25 s" and duration(42.0) == "42.0 s"
    assert main(["route", str(ws.log), str(ws.log), "--out", str(tmp_path / "r"), "--no-figures"]) == 0
    printed = capsys.readouterr().out
    assert "0.00 s" not in printed and " ms" in printed, printed


def test_info_help_describes_the_command():
    done = subprocess.run(
        [sys.executable, "-m", "nightloc", "info", "--help"], capture_output=True, text=True, check=True
    )
    body = " ".join(done.stdout.split("options:")[0].split())
    assert "SIMD paths" in body and "byte comparisons per second" in body, done.stdout


def test_build_map_creates_the_maps_folder_and_removes_it_again_on_a_failure(ws, capsys, tmp_path):
    target = tmp_path / "maps" / "nested" / "forward.map"
    assert main(["build-map", str(ws.forward), str(target), "--camera", "forward"]) == 0
    assert ReferenceMap.load(target).camera == "forward"
    capsys.readouterr()
    # a failure after the check (frames too narrow for the default panorama) leaves no folder behind
    broken = nightloc.save_traverse(tmp_path / "broken", ws.forward_frames[:3], ws.positions[:3], ws.headings[:3])
    (broken.root / "images" / broken.names[2]).write_bytes(b"not an image")
    assert main(["build-map", str(broken.root), str(tmp_path / "new" / "x.map"), "--camera", "forward"]) == 2
    assert broken.names[2] in capsys.readouterr().err
    assert not (tmp_path / "new").exists()
