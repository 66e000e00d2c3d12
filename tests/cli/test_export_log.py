"""``nightloc export-log LOG OUT``: the command around write_firmware_log (tests/io/test_firmware_log.py):
what it prints, and the inputs it refuses before any work, the user's files untouched."""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.io.kinds import MAP
from nightloc.motion.odometry import RobotMotion


@pytest.fixture
def log(tmp_path):
    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 256, (12, 20), dtype=np.uint8) for _ in range(4)]
    motions = [RobotMotion(0.2, 0.0, 0.1)] * 4
    return nightloc.save_traverse(tmp_path / "log", frames, np.zeros((4, 2)), odometry=motions).root


def test_it_says_what_it_wrote_and_how_to_replay_it(log, tmp_path, capsys):
    assert main(["export-log", str(log), str(tmp_path / "a" / "b")]) == 0
    out = capsys.readouterr().out
    assert f"wrote {tmp_path / 'a' / 'b'}: 4 PGM frames, odometry.csv, poses.csv" in out
    assert f"nightloc_replay MAP {tmp_path / 'a' / 'b'} trajectory.csv" in out
    assert sorted(p.name for p in (tmp_path / "a" / "b" / "images").iterdir())[0] == "000000.pgm"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (lambda log, tmp: [str(log), str(log / "fw")], "lies inside the input"),
        (lambda log, tmp: [str(log), str(log)], "is the input"),
        (lambda log, tmp: [str(tmp / "nowhere"), str(tmp / "out")], "nowhere"),
        (lambda log, tmp: [str(log), str(tmp / "out"), "--odometry", str(tmp / "none.csv")], "none.csv"),
    ],
    ids=["inside-the-log", "the-log-itself", "no-log", "no-odometry-file"],
)
def test_bad_inputs_are_one_line_and_write_nothing(log, tmp_path, capsys, argv, message):
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    assert main(["export-log", *argv(log, tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nightloc export-log: error: ") and message in err and err.count("\n") == 1, err
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_a_log_without_odometry_names_the_file_and_the_option(log, tmp_path, capsys):
    (log / "odometry.csv").unlink()
    assert main(["export-log", str(log), str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"the log {log} has no odometry.csv" in err and "--odometry FILE" in err and "--odometry none" not in err


def test_an_existing_out_needs_overwrite(log, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["export-log", str(log), str(out)]) == 0
    assert main(["export-log", str(log), str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["export-log", str(log), str(out), "--overwrite"]) == 0


def test_a_map_given_as_the_log_says_so(log, tmp_path, capsys):
    map_file = nightloc.ReferenceMap.build(nightloc.load_traverse(log)).save(tmp_path / "day.map")
    assert main(["export-log", str(map_file), str(tmp_path / "out")]) == 2
    assert f"LOG {map_file} is {MAP}, not a traverse" in capsys.readouterr().err
