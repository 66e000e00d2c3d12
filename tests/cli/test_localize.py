"""``nightloc localize``: a night log (frames + odometry.csv) to trajectory.csv and a figure."""

from __future__ import annotations

import csv

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.commands.localize import TRAJECTORY_HEADER
from nightloc.motion.odometry import WHEEL_ODOMETRY_NOISE

from synth_support import default_synth_data


def _rows(path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return rows[0], rows[1:]


def test_localize_writes_the_trajectory_and_prints_errors_against_poses(tmp_path, capsys):
    folders = default_synth_data()["garden"]
    out = tmp_path / "run"
    assert main(["localize", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "median" in printed and "90th percentile" in printed
    assert "from frame 10 on (32 frames)" in printed and "p95" in printed and "longest run" in printed
    header, rows = _rows(out / "trajectory.csv")
    assert tuple(header) == TRAJECTORY_HEADER
    log = nightloc.load_traverse(folders["night_query"])
    assert [r[0] for r in rows] == list(log.names)
    values = np.array([[float(v) for v in r[1:6]] for r in rows])
    assert np.isfinite(values).all() and (values[:, 3] >= 0).all() and (values[:, 3] <= 1).all()
    # the same numbers as the API on the same frames and odometry
    ref_map = nightloc.ReferenceMap.build(folders["day_reference"])
    odometry = nightloc.motion.odometry.traverse_odometry(log)
    # a log of wheel odometry: the filter assumes the step-scaled wheel model by default
    assert isinstance(odometry[1], nightloc.RobotMotion)
    loc = nightloc.Localizer(ref_map, odometry_noise=WHEEL_ODOMETRY_NOISE)
    expected = [loc.update(log.read(i), odometry[i]) for i in range(len(log))]
    np.testing.assert_allclose(values[:, 0], [e.x for e in expected], atol=1e-4)
    errors = np.hypot(values[:, 0] - log.positions[:, 0], values[:, 1] - log.positions[:, 1])
    assert np.median(errors[9:]) < 0.5
    image = cv2.imread(str(out / "trajectory.png"))
    assert image is not None and image.shape[2] == 3


def test_localize_odometry_noise_option_names_the_model(tmp_path):
    folders = default_synth_data()["garden"]
    log = nightloc.load_traverse(folders["night_query"])
    odometry = nightloc.motion.odometry.traverse_odometry(log)
    ref_map = nightloc.ReferenceMap.build(folders["day_reference"])
    for option, noise in (("1", 1), ("wheel", WHEEL_ODOMETRY_NOISE)):
        out = tmp_path / option
        argv = ["localize", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(out)]
        assert main([*argv, "--no-figures", "--odometry-noise", option]) == 0
        _, rows = _rows(out / "trajectory.csv")
        loc = nightloc.Localizer(ref_map, odometry_noise=noise)
        expected = [loc.update(log.read(i), odometry[i]) for i in range(len(log))]
        np.testing.assert_allclose([float(r[1]) for r in rows], [e.x for e in expected], atol=1e-4)
    # the two models differ on this log: the option is not ignored
    _, model1 = _rows(tmp_path / "1" / "trajectory.csv")
    _, wheel = _rows(tmp_path / "wheel" / "trajectory.csv")
    assert [r[1:3] for r in model1] != [r[1:3] for r in wheel]


def test_localize_a_log_without_poses_from_a_map_file_and_map_frame_odometry(tmp_path, capsys):
    folders = default_synth_data()["living_room"]
    log = nightloc.load_traverse(folders["night_query"])
    steps = np.vstack([np.zeros((1, 2)), np.diff(log.positions, axis=0)])
    night = nightloc.save_traverse(
        tmp_path / "night", (log.read(i) for i in range(len(log))), odometry=[tuple(s) for s in steps]
    )
    assert (night.root / "odometry.csv").read_text().splitlines()[0] == "image,dx,dy"
    map_file = tmp_path / "lr.npz"
    assert main(["build-map", str(folders["day_reference"]), str(map_file)]) == 0
    out = tmp_path / "out"
    assert main(["localize", str(map_file), str(night.root), "--out", str(out), "--no-figures"]) == 0
    printed = capsys.readouterr().out
    assert "median" not in printed  # no poses: nothing to compare with
    _, rows = _rows(out / "trajectory.csv")
    assert len(rows) == len(log) and not (out / "trajectory.png").exists()
    xy = np.array([[float(r[1]), float(r[2])] for r in rows])
    assert np.median(np.hypot(*(xy - log.positions).T)[9:]) < 0.5


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--odometry", "missing.csv"], "does not exist"),
        (["--odometry-noise", "9"], "noise model"),
        (["--threads", "0"], "--threads"),
    ],
)
def test_localize_errors_are_one_line(tmp_path, capsys, extra, message):
    folders = default_synth_data()["garden"]
    argv = ["localize", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(tmp_path / "o")]
    assert main([*argv, *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nightloc localize: error:") and message in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_localize_a_log_without_odometry_file_names_it(tmp_path, capsys):
    folders = default_synth_data()["garden"]
    log = nightloc.load_traverse(folders["night_query"])
    bare = nightloc.save_traverse(tmp_path / "bare", (log.read(i) for i in range(3)))
    assert main(["localize", str(folders["day_reference"]), str(bare.root), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "odometry.csv" in err and "forward,left,turn" in err
    # --odometry none: every motion unknown, still a trajectory
    assert main(["localize", str(folders["day_reference"]), str(bare.root), "--out", str(tmp_path / "o"),
                 "--odometry", "none", "--no-figures"]) == 0  # fmt: skip
    assert len(_rows(tmp_path / "o" / "trajectory.csv")[1]) == 3
